"""Placement probes at several heights for the pairs a constraint names together: a check that one object rests on
another (a tower level) is True only in a band of heights, and one draw per pair can miss it; the check is then read
as "can never be satisfied" and the program rejected, when the world is only far from it (the tower already fell),
which is a violation to raise, not a bad program."""

from __future__ import annotations

import numpy as np
import pytest

from code_as_monitor.core import Constraint, Phase
from code_as_monitor.monitor.coverage import CoverageError, check_path_coverage
from code_as_monitor.monitor.perturb import MAX_PLACEMENTS, PLACEMENT_HEIGHTS, PLACEMENT_LIFT, make_probes
from code_as_monitor.monitor.sandbox import Sandbox

# tip, three blocks: 2 fell off 3 and lies on the table beside it; 1 is held under the tip
FALLEN = {0: np.array([[0.50, 0.10, 0.20]]), 1: np.array([[0.50, 0.10, 0.176]]),
          2: np.array([[0.53, -0.05, 0.02]]), 3: np.array([[0.45, 0.0, 0.02]])}

STILL_ON = '''
def check_attached(E, H, t):
    d = distance(E[0], centroid(E[1]))
    return d <= {reach}, "tip %.3f m from the block" % d

def check_tower(E, H, t):
    off = horizontal_distance(E[2], E[3])
    dz = centroid(E[2])[2] - centroid(E[3])[2]
    if off <= 0.025 and dz >= {lo} and dz <= {hi}:
        return True, "still on (offset %.3f m)" % off
    return False, "no longer on (offset %.3f m, height difference %.3f m)" % (off, dz)
'''


def _constraints() -> list[Constraint]:
    return [Constraint("attached", "the block stays on the tip", Phase.DURING, element_ids=[0, 1]),
            Constraint("tower", "block 2 is still on block 3", Phase.DURING, element_ids=[2, 3])]


def test_pairs_named_together_are_placed_at_every_height_stratum() -> None:
    related = [[0, 1], [2, 3]]
    probes = make_probes(FALLEN, None, None, 1.0, 8, seed=5, related=related)
    lo, hi = PLACEMENT_LIFT
    edges = np.linspace(lo, hi, PLACEMENT_HEIGHTS + 1)
    for i, j in [(0, 1), (1, 0), (2, 3), (3, 2)]:
        placed = [p for p in probes if p.description.startswith(f"element {i} placed")
                  and f"above element {j} " in p.description]
        gaps = sorted(float(p.elements[i][:, 2].min() - FALLEN[j][:, 2].max()) for p in placed)
        assert len(gaps) == PLACEMENT_HEIGHTS
        for g, a, b in zip(gaps, edges[:-1], edges[1:]):
            assert a - 1e-9 <= g <= b + 1e-9
    once = [p for p in probes if p.description.startswith("element 2 placed") and "above element 0 " in p.description]
    assert len(once) == 1, "a pair no constraint names together keeps one placement"
    unrelated = make_probes(FALLEN, None, None, 1.0, 8, seed=5)
    assert sum("placed" in p.description for p in unrelated) == 12


def test_the_placement_budget_holds_with_many_related_pairs() -> None:
    scene = {i: np.array([[0.3 + 0.02 * i, 0.0, 0.02]]) for i in range(12)}
    probes = make_probes(scene, None, None, 1.0, 4, seed=1, related=[list(range(12))])
    assert sum("placed" in p.description for p in probes) == MAX_PLACEMENTS * PLACEMENT_HEIGHTS


@pytest.mark.parametrize("seed", range(6))
def test_a_fallen_tower_level_is_a_violation_not_a_check_that_can_never_hold(seed: int) -> None:
    cons = _constraints()
    with Sandbox(deadline_s=0.15) as box:
        report = check_path_coverage(STILL_ON.format(reach=0.05, lo=0.02, hi=0.06), cons, FALLEN, None, None, 1.0,
                                     box, seed=seed)
        assert [v.constraint_id for v in report.violated_at_start] == ["tower"]
        with pytest.raises(CoverageError, match="check_tower: returned False on all"):
            check_path_coverage(STILL_ON.format(reach=0.05, lo=0.5, hi=0.4), cons, FALLEN, None, None, 1.0, box,
                                seed=seed)
