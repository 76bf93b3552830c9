"""``cam report``: Markdown in the paper's layout and a self-contained HTML page from constructed results."""

from __future__ import annotations

import json

from code_as_monitor.bench.report import wall_time
from code_as_monitor.cli.main import main


def _results(path, video=None) -> None:
    lines = [{"kind": "bench_start", "options": {"backend": "kb"}, "epoch": 1000.0}]
    for method in ("open-loop", "inner-monologue", "doremi", "cam"):
        for seed in range(2):
            for ep in range(2):
                ok = method != "open-loop" or ep == 0
                lines.append({
                    "kind": "episode", "condition": "stack-p0.3", "method": method, "seed": seed, "episode": ep,
                    "success": ok, "sim_time_s": 10.0 + ep, "wall_time_s": 1.0, "finished_at": 1060.0,
                    "vlm": {"calls": 4, "total_tokens": 900},
                    "alarms": [] if method == "open-loop" else [{"t": 2.5, "proactive": False,
                                                                "objects": ["robot", "green_block"]}],
                    "gt": [{"t": 2.0, "kind": "drop", "obj": "green_block"}],
                    "video": video if (seed, ep) == (0, 0) else None, "error": None,
                })
    path.write_text("\n".join(json.dumps(x) for x in lines) + "\n")


def test_report_writes_markdown_and_self_contained_html(tmp_path, capsys):
    (tmp_path / "runs").mkdir()
    video = tmp_path / "runs" / "episode.mp4"
    video.write_bytes(b"x")
    res = tmp_path / "r.jsonl"
    _results(res, str(video))
    assert main(["report", str(res), "--out", str(tmp_path / "rep"), "--print"]) == 0
    md = (tmp_path / "rep" / "report.md").read_text()
    assert "| Stack in order, p=0.3 | 4 | 50.0 ± " in md  # open-loop: per-seed 50 %, 50 % -> CI 0
    assert "SR +Ours (CaM)" in md and "21.67 ± 8.33" in md  # our row and the paper's
    assert "R 100% (4/4)" in md and "vqa-standin" in md
    page = (tmp_path / "rep" / "report.html").read_text()
    assert page.count("data:image/png;base64,") == 3 and "<table>" in page
    assert 'href="../runs/episode.mp4"' in page
    assert "1.0 min" in md


def test_wall_time_sums_sessions_including_killed_ones():
    lines = [{"kind": "bench_start", "epoch": 0.0}, {"kind": "episode", "finished_at": 50.0},
             {"kind": "bench_start", "epoch": 100.0}, {"kind": "episode", "finished_at": 130.0},
             {"kind": "bench_end"}]
    assert wall_time(lines) == 80.0


def test_missing_results_exit_2(tmp_path, capsys):
    assert main(["report", str(tmp_path / "none.jsonl")]) == 2
    assert "no such file" in capsys.readouterr().err


def _one_seed(path, successes) -> None:
    recs = [{"kind": "episode", "condition": "stack-p0.15", "method": "open-loop", "seed": 0, "episode": e,
             "success": ok, "sim_time_s": 10.0, "wall_time_s": 1.0, "vlm": {"calls": 0, "total_tokens": 0},
             "alarms": [], "gt": []} for e, ok in enumerate(successes)]
    path.write_text("\n".join(json.dumps(r) for r in recs) + "\n")


def test_intervals_are_labelled_and_clipped_to_0_100(tmp_path, capsys):
    res = tmp_path / "r.jsonl"
    _one_seed(res, [True, False, False, False])  # 25 % +- t(0.975, 3) * 50 / 2 = 79.6: past 0 and 100
    assert main(["report", str(res), "--out", str(tmp_path / "rep"), "--print"]) == 0
    md = capsys.readouterr().out
    assert "| Stack in order, p=0.15 | 4 | 25.0 (0.0–100.0)† |" in md
    assert "95 % t-interval" in md and "over episodes, as each cell has a single seed (n = 4 episodes)" in md
    assert "† the interval reaches past 0–100 %" in md and "clipped" in md
    _one_seed(res, [True] * 7 + [False])  # 87.5 % +- 29.6: only the upper end is clipped
    assert main(["report", str(res), "--out", str(tmp_path / "rep"), "--print"]) == 0
    assert "| 8 | 87.5 (57.9–100.0)† |" in capsys.readouterr().out


def test_seed_level_intervals_say_so(tmp_path, capsys):
    res = tmp_path / "r.jsonl"
    _results(res)
    assert main(["report", str(res), "--out", str(tmp_path / "rep"), "--print"]) == 0
    assert "over seeds (the per-seed means; n = 2 seeds)" in capsys.readouterr().out


def test_clipped_interval():
    from code_as_monitor.bench.report import clipped_interval

    assert clipped_interval({"mean": 25.0, "ci": 79.6}, 0.0, 100.0) == (0.0, 100.0, True)
    assert clipped_interval({"mean": 50.0, "ci": 10.0}, 0.0, 100.0) == (40.0, 60.0, False)
    lo, hi, clipped = clipped_interval({"mean": 5.0, "ci": float("nan")}, 0.0, 100.0)
    assert (lo, hi, clipped) == (5.0, 5.0, False)


def test_empty_results_file_is_one_line_exit_2(tmp_path, capsys):
    res = tmp_path / "r.jsonl"
    res.write_text("")
    assert main(["report", str(res)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no episode records" in err[0]
    assert not (tmp_path / "r-report").exists()


def test_cost_table_gives_cam_over_doremi_tokens(tmp_path):
    lines = [{"kind": "bench_start", "options": {"backend": "kb"}, "epoch": 1000.0}]
    for method, tokens in (("doremi", [1000, 3000]), ("cam", [500, 700])):
        for ep, n in enumerate(tokens):
            lines.append({"kind": "episode", "condition": "stack-p0", "method": method, "seed": 0, "episode": ep,
                          "success": True, "sim_time_s": 10.0, "wall_time_s": 1.0, "finished_at": 1010.0,
                          "vlm": {"calls": 4, "total_tokens": n}, "alarms": [], "gt": [], "error": None})
    res = tmp_path / "r.jsonl"
    res.write_text("\n".join(json.dumps(x) for x in lines) + "\n")
    assert main(["report", str(res), "--out", str(tmp_path / "rep")]) == 0
    md = (tmp_path / "rep" / "report.md").read_text()
    assert "estimates offline; last column CaM / DoReMi tokens" in md
    assert "| +DoReMi | +Ours (CaM) | CaM / DoReMi tokens |" in md
    assert "/ 2000 / " in md and "/ 600 / " in md and "| 0.30x |" in md  # means 600 / 2000
