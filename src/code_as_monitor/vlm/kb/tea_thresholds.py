"""The knowledge base's thresholds for ``pour-tea``.

Merged into :data:`code_as_monitor.vlm.kb.thresholds.THRESHOLDS`.

Physical tolerances from the object sizes in sim/assets (``teapot.urdf``: an 11 cm pot, its spout a 9 cm trough
rising 35 degrees, the handle a 5 x 5 cm fin; ``teacup.urdf``: an 8.2 cm opening, 7 cm tall), never fitted to
evaluation outcomes. Units: metres, radians, fractions.
"""

from __future__ import annotations

import math

SPOUT_SLOPE = math.radians(35.0)
"""The spout trough's rise above the pot's floor plane: tilted forward past this, the trough slopes down and
the tea runs out."""

TEA_THRESHOLDS: dict[str, dict[str, float]] = {
    # grasp, upon: the handle's (painted) centre within 4 cm of the grasp point (the fin is 5 x 5 cm: the centre
    # of its visible faces can be 2.5 cm off its true centre) and above 10 cm (5 cm when the pot stands on the
    # table, the grasp lifts it to 22 cm).
    "teapot_lifted": {"max_dist": 0.04, "min_z": 0.10},
    # transport, pour, drain, level, during: the handle stays within 5 cm of the grasp point; a dropped pot
    # falls to the table, 10 cm or more below it.
    "teapot_gripped": {"max_dist": 0.05},
    # transport, during: the lid (its normal) within 15 degrees of vertical: "level within 15 degrees"; at 35
    # degrees forward the trough slopes down and the tea runs out.
    "teapot_carried_level": {"max_tilt": math.radians(15.0)},
    # level and set_down, upon: the lid within 15 degrees of vertical (the same "level").
    "teapot_level": {"max_tilt": math.radians(15.0)},
    # transport, upon, and pour, drain, during (proactive): the spout's (painted) centre within 8 cm
    # (horizontally) of the cup's centre: the opening's half-width (4.1 cm) plus the 4 cm the trough's centre lies
    # behind its end (4.5 cm along a 35-degree slope), where the tea leaves.
    "spout_over_cup": {"max_offset": 0.08},
    # pour, upon: tipped forward at least 50 degrees (the handle-to-spout line, about horizontal when level, slopes
    # down that much): the trough, rising SPOUT_SLOPE when level, then slopes 15 degrees down and the tea rolls out.
    "teapot_poured": {"min_tilt": math.radians(50.0)},
    # drain, during: it stays tipped at least 40 degrees (the trough 5 degrees down, the tea still runs);
    # back towards level the tea stops and rolls back into the pot.
    "teapot_draining": {"min_tilt": math.radians(40.0)},
    # set_down, upon: let go: the grasp point at least 6 cm from the handle's centre (beyond its 4 cm slack).
    "teapot_freed": {"release_dist": 0.06},
}
