"""The CLIPort benchmark protocol: conditions, methods, seeds x episodes, and episode seeds.

Two suites. ``cliport``: the rows of the paper's Table 1 (supplementary "Detailed Performance in
CLIPort"): stack-in-order with drop probability p in {0, 0.15, 0.3} (no placement noise), with
placement noise q in {1, 2, 3} cm (no drops), sweep-half and rope-close-square. ``stack-p0`` is the
undisturbed condition (false alarms are counted there). ``table2``: the paper's Table 2 layout
(OmniGibson: None, (a), (b), (c) per task, 10 runs each); slot-pen, stow-book, pour-tea, plus open-drawer
(articulated, the paper's RLBench kind of object). ``rlbench``: the paper's RLBench table (supplementary,
"Performance in RLBench"): six tasks with four cameras and a noisy policy (the learned-policy analogue, no
disturbance); a flagged episode is abandoned and another started until each cell has its valid episodes
(:mod:`code_as_monitor.bench.restarts`). ``instructions``: conditions whose goal an instruction sets
(a reversed tower, a two-block tower, 10 blocks swept, a drawer opened 10 cm, half of the rope square's opening
closed), to run instructions end to end. ``ablation``: the paper's ablation table (stow-book, MV / CS / CP off, 10
runs per disturbance setting) on the Table 2 conditions of slot-pen, stow-book and pour-tea, with CaM's ablation
settings as methods (``cam-mv-off`` ... ; :mod:`code_as_monitor.agent.ablations`), plus reactive-only and
proactive-only rows (the paper's supplementary table, IDs C and D).

Episode seed: :func:`episode_seed` is a deterministic hash of (condition id, seed index, episode
index), so every method sees the same scene and the same disturbance draws for the same key (as far
as the methods' own actions leave the simulator on the same path).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from typing import Any

from code_as_monitor.core.checks import check_count
from code_as_monitor.core.errors import ConfigError


@dataclass(frozen=True)
class Condition:
    """One row: a task with its disturbance parameters. ``undisturbed``: no disturbance at all."""

    id: str
    task: str
    params: dict[str, Any] = field(default_factory=dict)
    label: str = ""
    undisturbed: bool = False
    suite: str = "cliport"


CONDITIONS: tuple[Condition, ...] = (
    Condition("stack-p0", "stack-in-order", {"p": 0.0}, "Stack in order, p=0.0", undisturbed=True),
    Condition("stack-p0.15", "stack-in-order", {"p": 0.15}, "Stack in order, p=0.15"),
    Condition("stack-p0.3", "stack-in-order", {"p": 0.3}, "Stack in order, p=0.3"),
    Condition("stack-q1", "stack-in-order", {"q": 1.0}, "Stack in order, q=1"),
    Condition("stack-q2", "stack-in-order", {"q": 2.0}, "Stack in order, q=2"),
    Condition("stack-q3", "stack-in-order", {"q": 3.0}, "Stack in order, q=3"),
    Condition("sweep-half", "sweep-half", {}, "Sweep half the blocks"),
    Condition("rope", "rope-close-square", {}, "Use rope to close the opening square"),
    Condition("pen-none", "slot-pen", {}, "Slot pen, None", undisturbed=True, suite="table2"),
    Condition("pen-a", "slot-pen", {"disturbance": "a"}, "Slot pen, (a) pen moved while grasping",
              suite="table2"),
    Condition("pen-b", "slot-pen", {"disturbance": "b"}, "Slot pen, (b) pen dropped in transport",
              suite="table2"),
    Condition("pen-c", "slot-pen", {"disturbance": "c"}, "Slot pen, (c) holder moved during insertion",
              suite="table2"),
    Condition("book-none", "stow-book", {}, "Stow book, None", undisturbed=True, suite="table2"),
    Condition("book-a", "stow-book", {"disturbance": "a"}, "Stow book, (a) book turned while grasping",
              suite="table2"),
    Condition("book-b", "stow-book", {"disturbance": "b"}, "Stow book, (b) book tilted in transport",
              suite="table2"),
    Condition("book-c", "stow-book", {"disturbance": "c"}, "Stow book, (c) book laid flat after placement",
              suite="table2"),
    Condition("tea-none", "pour-tea", {}, "Pour tea, None", undisturbed=True, suite="table2"),
    Condition("tea-a", "pour-tea", {"disturbance": "a"}, "Pour tea, (a) teapot tilts forward/back in transport",
              suite="table2"),
    Condition("tea-b", "pour-tea", {"disturbance": "b"}, "Pour tea, (b) teapot tilts sideways in transport",
              suite="table2"),
    Condition("tea-c", "pour-tea", {"disturbance": "c"}, "Pour tea, (c) teapot back to level while pouring",
              suite="table2"),
    Condition("drawer-none", "open-drawer", {}, "Open drawer, None", undisturbed=True, suite="table2"),
    Condition("drawer-slip", "open-drawer", {"disturbance": "slip"}, "Open drawer, grasp slips off the handle",
              suite="table2"),
    # Goals set by an instruction (the task's goal parameters and success check follow it; see TaskConfig).
    Condition("stack-reversed", "stack-in-order", {"instruction": "stack red on top of green on top of blue"},
              "Stack in order, blue at the bottom (instruction)", undisturbed=True, suite="instructions"),
    Condition("stack-two", "stack-in-order", {"instruction": "put the blue block on the red block", "p": 0.15},
              "Stack two blocks, p=0.15 (instruction)", suite="instructions"),
    Condition("sweep-ten", "sweep-half", {"instruction": "push 10 blocks into the zone"},
              "Sweep 10 of 40 blocks, 9-11 accepted (instruction)", suite="instructions"),
    Condition("drawer-ten", "open-drawer", {"instruction": "open the drawer 10 cm", "disturbance": "slip"},
              "Open drawer 10 cm, grasp slips off the handle (instruction)", suite="instructions"),
    Condition("rope-half", "rope-close-square", {"instruction": "close half of the opening with the rope"},
              "Close half of the rope square's opening (instruction)", suite="instructions"),
    Condition("tap-sixty", "turn-tap", {"instruction": "turn the right tap 60 degrees"},
              "Turn the right tap 60 degrees, noisy policy (instruction)", suite="instructions"),
    Condition("rlb-open-drawer", "open-drawer", {"noise": 1.0, "views": "rlbench"}, "Open drawer", undisturbed=True,
              suite="rlbench"),
    Condition("rlb-put-in-drawer", "put-in-drawer", {}, "Put in drawer", undisturbed=True, suite="rlbench"),
    Condition("rlb-screw-bulb", "screw-bulb", {}, "Screw bulb", undisturbed=True, suite="rlbench"),
    Condition("rlb-turn-tap", "turn-tap", {}, "Turn tap", undisturbed=True, suite="rlbench"),
    Condition("rlb-drag-stick", "drag-stick", {}, "Drag stick", undisturbed=True, suite="rlbench"),
    Condition("rlb-sweep-to-dustpan", "sweep-to-dustpan", {}, "Sweep to dustpan", undisturbed=True,
              suite="rlbench"),
)
CONDITION_BY_ID = {c.id: c for c in CONDITIONS}
SUITES: dict[str, tuple[str, ...]] = {
    s: tuple(c.id for c in CONDITIONS if c.suite == s) for s in ("cliport", "table2", "instructions", "rlbench")
}
# The ablation runs on Table 2's conditions of the paper's three ablated tasks, stow-book first (the paper's table).
SUITES["ablation"] = tuple(c.id for t in ("stow-book", "slot-pen", "pour-tea") for c in CONDITIONS
                           if c.suite == "table2" and c.task == t)
SUITE_DEFAULTS: dict[str, dict[str, Any]] = {
    "cliport": {"seeds": 5, "episodes": 12, "methods": ("open-loop", "inner-monologue", "doremi", "cam")},
    # The paper's 10 runs per setting. Offline, DoReMi and Inner Monologue ask the single-image VQA
    # stand-in (not a VLM): it has rules for the pen/holder and book/shelf constraints
    # (baselines/vqa_standin_gripper.py), the drawer's (baselines/vqa_standin_drawer.py) and the teapot's
    # (baselines/vqa_standin_tea.py), each answering from one front image with a single image's mistakes.
    "table2": {"seeds": 1, "episodes": 10, "methods": ("open-loop", "inner-monologue", "doremi", "cam")},
    # Instructions other than the paper's: the goal parameters they map to, end to end.
    "instructions": {"seeds": 1, "episodes": 4, "methods": ("open-loop", "cam")},
    # The paper's RLBench table: ARP alone, +DoReMi, +CaM, 1000 valid episodes per task there. ``episodes`` is the
    # valid episodes wanted per cell; a flagged one is abandoned (``max_replans`` 0) and another drawn, up to
    # ``max_attempts_factor`` x ``episodes`` attempts (bench.restarts).
    "rlbench": {"seeds": 1, "episodes": 20, "methods": ("open-loop", "doremi", "cam"), "restarts": True,
                "max_attempts_factor": 3, "options": {"max_replans": 0}},
    # The paper's ablation: 10 runs per setting, rows = CaM's ablation settings.
    "ablation": {"seeds": 1, "episodes": 10, "methods": ("cam", "cam-mv-off", "cam-cs-off", "cam-cp-off",
                                                          "cam-reactive-only", "cam-proactive-only")},
}

METHODS: tuple[str, ...] = ("open-loop", "inner-monologue", "doremi", "cam")
"""Column order: the paper's CLIPort, +Inner Monologue, +DoReMi, +Ours."""
ABLATION_METHODS: tuple[str, ...] = ("cam-mv-off", "cam-cs-off", "cam-cp-off", "cam-reactive-only",
                                     "cam-proactive-only")
"""CaM with one ablation setting each: ``cam-<name>`` runs ``ClosedLoopConfig(ablation=<name>)``."""
ALL_METHODS: tuple[str, ...] = METHODS + ABLATION_METHODS


def is_cam(method: str) -> bool:
    """Whether ``method`` is Code-as-Monitor (full, or one of its ablation settings)."""
    return method == "cam" or method in ABLATION_METHODS


def ablation_of(method: str) -> str:
    """The ablation setting of a CaM method (``full`` for ``cam``); ConfigError for another method."""
    if not is_cam(method):
        raise ConfigError(f"{method!r} is not a Code-as-Monitor method")
    return "full" if method == "cam" else method[len("cam-"):]

FULL = (5, 12)
QUICK = (1, 4)


def condition(cid: str) -> Condition:
    """The condition ``cid``; ConfigError naming the known ids otherwise."""
    if cid not in CONDITION_BY_ID:
        raise ConfigError(f"unknown condition {cid!r}; known: {', '.join(CONDITION_BY_ID)}")
    return CONDITION_BY_ID[cid]


def episode_seed(condition_id: str, seed: int, episode: int) -> int:
    """Deterministic 31-bit simulator seed of one episode key."""
    h = hashlib.sha256(f"{condition_id}|{seed}|{episode}".encode()).digest()
    return int.from_bytes(h[:4], "big") & 0x7FFFFFFF


@dataclass(frozen=True)
class Job:
    """One episode to run: method x condition x seed index x episode index."""

    method: str
    condition: str
    seed: int
    episode: int

    @property
    def key(self) -> tuple[str, str, int, int]:
        return (self.condition, self.method, self.seed, self.episode)


@dataclass
class BenchSpec:
    """Which cells and how many episodes. ``options`` are the method settings that change results
    (backend, doremi k, tracker, ...); a results file keeps one set of options (checked on resume)."""

    methods: list[str] = field(default_factory=lambda: list(METHODS))
    conditions: list[str] = field(default_factory=lambda: list(SUITES["cliport"]))
    seeds: int = FULL[0]
    episodes: int = FULL[1]
    options: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        for m in self.methods:
            if m not in ALL_METHODS:
                raise ConfigError(f"unknown method {m!r}; known: {', '.join(ALL_METHODS)}")
        for c in self.conditions:
            condition(c)
        check_count("BenchSpec", "seeds", self.seeds, 1)
        check_count("BenchSpec", "episodes", self.episodes, 1)

    @classmethod
    def quick(cls, **kw: Any) -> BenchSpec:
        """1 seed x 4 episodes per condition."""
        return cls(seeds=QUICK[0], episodes=QUICK[1], **kw)

    def jobs(self) -> list[Job]:
        """Every episode, ordered so that partial results cover every cell early (episode-major)."""
        out = []
        for s in range(self.seeds):
            for e in range(self.episodes):
                for c in self.conditions:
                    for m in self.methods:
                        out.append(Job(m, c, s, e))
        return out


__all__ = [
    "ABLATION_METHODS",
    "ALL_METHODS",
    "CONDITIONS",
    "CONDITION_BY_ID",
    "FULL",
    "METHODS",
    "QUICK",
    "SUITES",
    "SUITE_DEFAULTS",
    "BenchSpec",
    "Condition",
    "Job",
    "ablation_of",
    "condition",
    "episode_seed",
    "is_cam",
]
