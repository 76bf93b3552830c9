"""The kb coder's point-only path (the ablation "CP off"): every line and surface arrives as unconnected point
elements; the programs recombine them in code, pass the monitor's gates, and decide as the full method's do."""

from __future__ import annotations

import copy

import numpy as np
import pytest
from test_vlm_kb_book import BOOK_STARTS
from test_vlm_kb_book import _chain as book_chain
from test_vlm_kb_manip import PEN_STARTS
from test_vlm_kb_manip import _chain as pen_chain
from test_vlm_kb_tea import TEA_STARTS
from test_vlm_kb_tea import _chain as tea_chain

from code_as_monitor.core import Element, ElementKind
from code_as_monitor.core.errors import VLMError
from code_as_monitor.painter.painter import assign_element_ids
from code_as_monitor.painter.point_elements import split_into_points
from code_as_monitor.planning import MonitorCoder
from code_as_monitor.vlm.kb import KBBackend
from code_as_monitor.vlm.kb.shared.points_only import group_points

CASES = [(book_chain, BOOK_STARTS, 3), (pen_chain, PEN_STARTS, 3), (tea_chain, TEA_STARTS, 5)]


def _subgoals(chain, n: int):
    return chain([None] + ["success"] * (n - 1))


def _split(subgoal, elements: list[Element]):
    sg = copy.deepcopy(subgoal)
    specs = assign_element_ids(sg)
    points, _, _ = split_into_points(elements, specs, sg)
    return sg, points


def _moved(elements: list[Element], rng: np.random.Generator) -> list[Element]:
    return [Element(e.id, e.name, e.kind, e.points + rng.normal(0.0, 0.03, size=(1, 3))
                    + rng.normal(0.0, 0.01, size=e.points.shape), e.owner) for e in elements]


@pytest.mark.parametrize(("chain", "starts", "n"), CASES, ids=["stow-book", "slot-pen", "pour-tea"])
def test_point_only_checks_decide_as_the_full_checks_do(chain, starts, n, make_elements, run_program) -> None:
    rng = np.random.default_rng(7)
    coder = MonitorCoder(KBBackend())
    compared = 0
    for subgoal, start in zip(_subgoals(chain, n), starts):
        full = make_elements(subgoal, start)
        sg, points = _split(subgoal, full)
        assert all(p.kind is ElementKind.POINT for p in points)
        src_full = coder.write_program(subgoal, full, {}, lambda s: None)
        src_pts = coder.write_program(sg, points, {}, lambda s: None)
        if any(e.kind is not ElementKind.POINT for e in full):
            assert "np.concatenate([E[" in src_pts and src_pts != src_full
        for _ in range(12):
            now = _moved(full, rng)
            _, now_pts = _split(subgoal, now)
            hist_full = [np.stack([a.points, b.points]) for a, b in zip(full, now)]
            hist_pts = [np.stack([a.points, b.points]) for a, b in zip(points, now_pts)]
            a = run_program(src_full, now, hist_full)
            b = run_program(src_pts, now_pts, hist_pts)
            assert a.keys() == b.keys()
            for cid in a:
                assert a[cid][0] == b[cid][0], (cid, a[cid], b[cid])
                if len(a[cid]) > 2:
                    assert a[cid][2] == pytest.approx(b[cid][2])
                compared += 1
    assert compared > 100


def test_points_out_of_order_are_refused_by_the_kb() -> None:
    legend = {0: {"name": "book spine p2/2", "obj": "book", "part": "spine", "kind": "point"},
              1: {"name": "book spine p1/2", "obj": "book", "part": "spine", "kind": "point"}}
    with pytest.raises(VLMError, match="not the first point"):
        group_points([0, 1], legend)
    with pytest.raises(VLMError, match="not listed together"):
        group_points([1, 1], legend)
    assert group_points([1, 0], legend) == [[1, 0]]


sandbox = pytest.importorskip("code_as_monitor.monitor.sandbox")


def test_point_only_book_programs_pass_validation_and_path_coverage(make_elements) -> None:
    from code_as_monitor.monitor import coverage, validate

    coder = MonitorCoder(KBBackend())
    box = sandbox.Sandbox()
    box.start()
    try:
        for subgoal, start in zip(_subgoals(book_chain, 3), BOOK_STARTS):
            sg, points = _split(subgoal, make_elements(subgoal, start))
            cons = sg.constraints
            src = coder.write_program(sg, points, {}, lambda s, cons=cons: validate.validate_program(s, cons))
            coverage.check_path_coverage(src, cons, {e.id: e.points for e in points}, None, None, 0.0, box,
                                     reject_failing_at_start=True)
    finally:
        box.close()
