"""A part seen as a few scattered pixels (one view, far apart points) has no points left once the isolated ones are
dropped: building it raises ElementError (the painter then reports it missing) instead of an IndexError in the box
fit (seen with the front view alone, ``cam run stow-book --ablation mv-off``)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from code_as_monitor.core import ElementSpec
from code_as_monitor.core.errors import ElementError
from code_as_monitor.geometry.elements import build_element_from_clouds


def test_scattered_points_give_an_element_error_naming_the_part() -> None:
    # four pairs of points 6 mm apart, 30 cm between pairs: each point has one neighbour, fewer than the 3
    # remove_isolated asks for, so none is left
    scattered = np.array([[0.3 * i + d, 0.0, 0.05] for i in range(4) for d in (0.0, 0.006)])
    view = SimpleNamespace(camera=SimpleNamespace(name="front"))
    with pytest.raises(ElementError, match=r"shelf slot.*bookshelf/slot.*no points left"):
        build_element_from_clouds(0, ElementSpec("shelf slot", "bookshelf", "slot", "surface"), [scattered], [view])
