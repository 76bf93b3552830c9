"""The knowledge base's thresholds for ``open-drawer``.

Merged into :data:`code_as_monitor.vlm.kb.thresholds.THRESHOLDS`.

Physical tolerances from the object sizes in sim/assets, never fitted to evaluation outcomes. Units: metres,
radians, fractions.

Sizes used (``sim/assets/drawer_cabinet.urdf``): the handle is a bar 10 cm long and 1.2 cm thick, 3.5 cm in
front of the drawer front; the drawer's tray is 22 cm deep; the gripper's fingers are 4.5 cm long and
its grasp point sits between them; its jaws open 8 cm.
"""

from __future__ import annotations

DRAWER_OPEN = 0.15
"""Metres a drawer must come out to count as open: more than half of a 22 cm deep tray, enough to reach in."""

DRAWER_THRESHOLDS: dict[str, dict[str, float]] = {
    # grasp, during (proactive): the handle stays where it is (within 2 cm) while the gripper approaches and
    # closes; a drawer pushed or pulled by 2 cm moves the 1.2 cm bar out of the closing jaws, which then close
    # on nothing. (The grasp does not lift the handle, so a held handle stays put as well.)
    "drawer_still": {"max_disp": 0.02},
    # grasp, upon: the handle's centre within 3 cm of the grasp point: jaws closed on a 1.2 cm bar hold it
    # within 1 cm, plus up to 2 cm for a handle point painted from the bar's visible pixels beside the fingers.
    "drawer_handle_grip": {"max_dist": 0.03},
    # grasp, upon: the jaws are closed on the bar: their opening between 1 cm and 5 cm (open it is 8 cm,
    # closed on nothing 0; on the 1.2 cm bar the fingers' pads leave a little clearance either side). The
    # handle is not lifted, so without this the grasp would look done while the open gripper passes the bar
    # on its way down.
    "drawer_jaw_shut": {"min_jaw": 0.01, "max_jaw": 0.05},
    # pull, during (reactive): the handle stays within 3 cm of the grasp point (as above) while the drawer is
    # less than DRAWER_OPEN out; once it is that far out, letting go is the plan.
    "drawer_handled": {"max_dist": 0.03, "min_open": DRAWER_OPEN},
    # pull, upon: the drawer front (its handle) has come out DRAWER_OPEN along the drawer's axis since the
    # pull began.
    "drawer_pulled": {"min_open": DRAWER_OPEN},
    # pull, upon: released: the grasp point 6 cm from the handle, beyond the 3 cm grip tolerance plus the
    # fingers' 3 cm reach past the bar (4.5 cm fingers, grasp point 5 mm inside their ends, 1.2 cm bar).
    "drawer_freed": {"release_dist": 0.06},
}
