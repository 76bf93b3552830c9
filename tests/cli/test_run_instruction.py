"""``cam run TASK --instruction``: the goal follows the instruction end to end; a bad one is one line, exit 2,
no run directory."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from code_as_monitor.cli.main import main


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["run", "stack-in-order", "--instruction", "stack the yellow block on the red block"], "no yellow block"),
        (["run", "stack-in-order", "--instruction", "push 10 blocks into the zone"], "sweep-half instruction"),
        (["run", "sweep-half", "--instruction", "juggle three oranges"], "did not understand 'juggle'"),
        (["run", "open-drawer", "--instruction", "open the drawer all the way"], "all the way"),
        (["run", "rope-close-square", "--instruction", "close at most half of the opening with the rope"],
         "cannot promise"),
        (["run", "stack-in-order", "--instruction", " "], "--instruction is empty"),
        (["run", "stack-in-order", "--timeout", "5"], "apply to the openai backend"),
    ],
)
def test_a_bad_instruction_is_one_line_exit_2_and_leaves_no_run(tmp_path: Path, capsys, argv, message) -> None:
    runs = tmp_path / "runs"
    assert main([*argv, "--runs", str(runs)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
    assert not runs.exists() or not any(runs.iterdir())


def test_run_with_an_instruction_builds_the_tower_it_asks_for(tmp_path: Path, capsys) -> None:
    pytest.importorskip("pybullet")
    runs = tmp_path / "runs"
    instruction = "put the blue block on the red block"
    argv = ["run", "stack-in-order", "--instruction", instruction, "--seed", "0", "--tracker", "sim",
            "--size", "160x120", "--no-video", "--runs", str(runs), "--quiet"]
    assert main(argv) == 0, capsys.readouterr()
    (run_dir,) = runs.iterdir()
    events = [json.loads(line) for line in (run_dir / "events.jsonl").read_text().splitlines()]
    assert events[0]["instruction"] == instruction
    actions = [e["subgoal"]["action"] for e in events if e.get("kind") == "subgoal" and e["subgoal"].get("action")]
    assert [a["args"]["obj"] for a in actions] == ["blue_block", "blue_block"]
    assert actions[-1] == {"skill": "place_on", "args": {"obj": "blue_block", "target": "red_block"}}
    summary = json.loads((run_dir / "summary.json").read_text())
    assert summary["success"] and "SUCCESS" in capsys.readouterr().out
