"""A part's whole object standing in for it is no evidence of where the part is (carry-over condition 2).

From one camera straight above the open-drawer scene (seed 7), the gripper that had just grasped the handle hid it;
the painter built the handle's element from the whole cabinet (``support.part_seen`` False), its centre 17 cm from
the jaws, and kept it over the remembered handle because the cabinet's 4234 points outnumbered the handle's 56: the
pull's "the grasp slipped off the handle" fired on its first frame. Figures from that run's ``element_carry``."""

from __future__ import annotations

import numpy as np

from code_as_monitor.core.elements import Element, ElementSpec, ElementSupport
from code_as_monitor.painter.carry_over import candidate, decide, known_from, stands_in

SPEC = ElementSpec("drawer cabinet handle", "drawer_cabinet", "handle")
HANDLE = (0.42, -0.05, 0.15)
CABINET = (0.55, 0.06, 0.1)


def _el(at, points: int, part_seen: bool, robot_hidden: float = 0.08) -> Element:
    return Element.point(1, SPEC.name, np.array(at), ("drawer_cabinet", "handle"),
                         support=ElementSupport(points, 1, 0.001, robot_hidden=robot_hidden, part_seen=part_seen))


def test_a_stand_in_is_a_candidate_and_the_remembered_part_is_carried_where_the_robot_hides_it():
    fresh = _el(CABINET, 4234, part_seen=False)
    assert stands_in(fresh) and candidate(fresh)
    known = known_from(_el(HANDLE, 56, part_seen=True, robot_hidden=0.0), np.array([HANDLE]), 2.1)
    el, d = decide(1, SPEC, fresh, known, 0.0, 0.0, 1.0)
    assert d.carried, d
    assert np.allclose(el.points, [HANDLE]) and d.figures["evidence_fresh"] == 0.0


def test_a_stand_in_stays_where_the_robot_does_not_hide_where_the_part_was():
    """Nothing says the part is still there: the stand-in stays (weak: its part unseen), as a missing element would."""
    fresh = _el(CABINET, 4234, part_seen=False)
    known = known_from(_el(HANDLE, 56, part_seen=True, robot_hidden=0.0), np.array([HANDLE]), 2.1)
    el, d = decide(1, SPEC, fresh, known, 0.0, 0.0, 0.0)
    assert not d.carried and el is fresh and el.support.weak()


def test_a_part_seen_with_more_points_than_remembered_is_kept():
    fresh = _el(HANDLE, 200, part_seen=True, robot_hidden=0.35)  # weak by the robot, but the part's own points
    assert not stands_in(fresh)
    known = known_from(_el(HANDLE, 56, part_seen=True, robot_hidden=0.0), np.array([HANDLE]), 2.1)
    _, d = decide(1, SPEC, fresh, known, 0.0, 0.0, 1.0)
    assert not d.carried and "no more unhidden points" in d.reason
