"""The kb rope check against the rope-close-square task's own success definition (issue #16).

The task (``sim/tasks/rope_close_square.py``) calls the opening enclosed when at least ``min_coverage`` of
``n_samples`` points from corner_3 to corner_0 have a resting bead (centre at most two bead radii plus 1 cm
high) within ``cover_tol`` horizontally. The kb's ``rope_covers_opening`` check must read the same definition
from the elements; its only deliberate difference is ``margin`` (a sample counts within ``max_gap - margin``,
for element error), which may make it stricter, never looser.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_vlm_kb import ROPE, gen_coder, infer_objects, program_for

from code_as_monitor.vlm.kb.families import rope


def _task():
    from code_as_monitor.sim.tasks.rope_close_square import RopeCloseSquareConfig, opening_coverage

    return RopeCloseSquareConfig(), opening_coverage


def _random_rope(rng: np.random.Generator, cfg) -> dict:
    """Opening along y at x = 0.5 (corner_3 at y = -0.1, corner_0 at y = +0.1, the square's inner half-size);
    beads on a wavy line about 1-3 cm outside it, a random run of them lifted (being carried)."""
    pts = {("square", "corner_0"): [0.5, 0.1, 0.0075], ("square", "corner_3"): [0.5, -0.1, 0.0075]}
    n = cfg.n_beads
    y = (np.arange(n) - (n - 1) / 2) * cfg.spacing * rng.uniform(0.7, 1.0) + rng.uniform(-0.03, 0.03)
    x = 0.5 + rng.uniform(0.005, 0.03) + 0.01 * np.sin(rng.uniform(0, 6) + y * rng.uniform(5, 40))
    z = np.full(n, cfg.bead_radius)
    if rng.random() < 0.4:
        k = int(rng.integers(0, n - 3))
        z[k:k + int(rng.integers(1, 4))] = 0.05
    for i in range(n):
        pts[("rope", f"bead_{i:02d}")] = [x[i], y[i], z[i]]
    return pts


def _task_coverage(pts: dict, cfg, opening_coverage) -> float:
    beads = np.array([v for k, v in pts.items() if k[0] == "rope"])
    resting = beads[beads[:, 2] <= 2 * cfg.bead_radius + 0.01, :2]
    if len(resting) == 0:
        return 0.0
    a = np.array(pts[("square", "corner_3")][:2])
    b = np.array(pts[("square", "corner_0")][:2])
    return opening_coverage(resting, a, b, cfg.cover_tol, cfg.n_samples)


def test_rope_thresholds_are_the_tasks_definition():
    cfg, _ = _task()
    th = rope.THRESHOLDS["rope_cover"]
    assert th["samples"] == cfg.n_samples
    assert th["max_gap"] == pytest.approx(cfg.cover_tol)
    assert th["min_fraction"] == pytest.approx(cfg.min_coverage)
    assert th["max_z"] == pytest.approx(2 * cfg.bead_radius + 0.01)
    assert 0.0 <= th["margin"] < th["max_gap"]


@pytest.mark.parametrize("margin", [0.0, None])
def test_rope_check_reads_the_tasks_coverage(margin, monkeypatch, make_elements, run_program):
    """Without the margin, the check's verdict on exact elements is the task's "enclosed" on 300 random rope
    states; with the kb's margin it never reads enclosed where the task reads open."""
    cfg, opening_coverage = _task()
    if margin is not None:
        monkeypatch.setitem(rope.THRESHOLDS, "rope_cover", {**rope.THRESHOLDS["rope_cover"], "margin": margin})
    gen, coder = gen_coder()
    sg = gen.next_subgoal(ROPE, {}, infer_objects(ROPE))
    rng = np.random.default_rng(16)
    src = None
    seen = {True: 0, False: 0}
    for _ in range(300):
        pts = _random_rope(rng, cfg)
        if src is None:
            src, _ = program_for(coder, sg, make_elements, pts)
        ok = run_program(src, make_elements(sg, pts))["rope_covers_opening"][0]
        enclosed = _task_coverage(pts, cfg, opening_coverage) >= cfg.min_coverage
        seen[enclosed] += 1
        if margin == 0.0:
            assert ok == enclosed, pts
        else:
            assert not ok or enclosed, pts
    assert min(seen.values()) >= 30  # both outcomes are exercised


def test_rope_beads_are_monotone_members_and_the_check_on_seen_beads_never_passes_an_open_opening(
        make_elements, run_program):
    """The beads are the constraint's monotone members: the agent may judge the check on the beads it sees
    (``Constraint.monotone``). On 300 random rope states, with a random third of the beads left out of E and H,
    the check is True only where it is True with every bead (a bead unseen can only add coverage), and it
    does say True on some states with beads unseen (the rule is not vacuous)."""
    cfg, _ = _task()
    gen, coder = gen_coder()
    sg = gen.next_subgoal(ROPE, {}, infer_objects(ROPE))
    (c,) = sg.constraints
    assert c.monotone == ["rope"]
    rng = np.random.default_rng(5)
    src = None
    passed_on_seen = 0
    for _ in range(300):
        pts = _random_rope(rng, cfg)
        if src is None:
            src, _ = program_for(coder, sg, make_elements, pts)
            assert "if i in H" in src
        els = make_elements(sg, pts)
        full = run_program(src, els)["rope_covers_opening"][0]
        hidden = set(rng.choice(range(2, len(els)), size=(len(els) - 2) // 3, replace=False).tolist())
        H = {e.id: np.stack([e.points, e.points]) for e in els if e.id not in hidden}
        ns: dict = {}
        seen = _run_on(src, {e.id: e.points for e in els if e.id not in hidden}, H, ns)
        assert not seen[0] or full, (pts, hidden)
        passed_on_seen += bool(seen[0])
        assert "beads seen" in seen[1]
    assert passed_on_seen >= 20


def _run_on(src: str, E: dict, H: dict, ns: dict) -> tuple:
    """The rope check on element and history mappings that lack some ids (trusted kb source, tests only)."""
    import math

    from code_as_monitor.geometry.helpers import MONITOR_HELPERS

    class _H(dict):
        t = np.array([0.0, 1.0])

    ns.update({"np": np, "math": math, **MONITOR_HELPERS})
    exec(compile(src, "<kb program>", "exec"), ns)
    return ns["check_rope_covers_opening"](E, _H(H), 1.0)


def _laid_rope(cfg, outward: float, shift: float = 0.0) -> dict:
    """The rope as the simulator's policy lays it (``rope_targets``: beads 85 % of their spacing apart along the
    opening, centred on it, ``outward`` metres outside it), every bead moved ``shift`` metres along the opening.
    Opening along y at x = 0.5, outside is +x."""
    pts = {("square", "corner_0"): [0.5, 0.1, 0.0075], ("square", "corner_3"): [0.5, -0.1, 0.0075]}
    n = cfg.n_beads
    y = (np.arange(n) - (n - 1) / 2) * cfg.spacing * 0.85 + shift
    for i in range(n):
        pts[("rope", f"bead_{i:02d}")] = [0.5 + outward, y[i], cfg.bead_radius]
    return pts


def _rope_check(make_elements, run_program, before: dict, now: dict, dt: float) -> bool:
    gen, coder = gen_coder()
    sg = gen.next_subgoal(ROPE, {}, infer_objects(ROPE))
    src, _ = program_for(coder, sg, make_elements, now)
    start, end = make_elements(sg, before), make_elements(sg, now)
    H = [np.stack([a.points, b.points]) for a, b in zip(start, end)]
    return run_program(src, end, H, t=dt)["rope_covers_opening"][0]


def test_a_laid_rope_read_a_few_mm_outward_is_enclosed(make_elements, run_program):
    """The policy lays the beads 15 mm outside the opening (every sample within 16.6 mm of a bead, inside the task's
    25 mm by 8 mm or more). Read 4 mm further out, as a settled bead or an estimate a few mm off may be (every sample
    within 20.3 mm, still 4.7 mm inside the task's tolerance), the check reads it enclosed; 24 mm out (samples up
    to 25.1 mm from a bead: the task's own borderline, 91 %) it does not."""
    cfg, opening_coverage = _task()
    near, far = _laid_rope(cfg, 0.019), _laid_rope(cfg, 0.024)
    assert _task_coverage(near, cfg, opening_coverage) == 1.0
    assert _rope_check(make_elements, run_program, near, near, 1.0)
    assert not _rope_check(make_elements, run_program, far, far, 1.0)

