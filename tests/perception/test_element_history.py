from __future__ import annotations

import numpy as np
import pytest

from code_as_monitor.core.errors import ConfigError, PerceptionError
from code_as_monitor.perception.history import ElementHistory


def _frame(i: int) -> dict[int, np.ndarray]:
    return {0: np.full((1, 3), float(i)), 3: np.full((4, 3), -float(i))}


def test_history_before_wrap():
    h = ElementHistory(maxlen=5)
    for i in range(3):
        h.push(0.1 * i, _frame(i))
    H, t = h.arrays()
    assert len(h) == 3 and H[0].shape == (3, 1, 3) and H[3].shape == (3, 4, 3)
    np.testing.assert_allclose(t, [0.0, 0.1, 0.2])
    np.testing.assert_allclose(H[0][:, 0, 0], [0, 1, 2])


@pytest.mark.parametrize("n", [5, 6, 7, 12, 13])
def test_history_wraps_oldest_first(n):
    h = ElementHistory(maxlen=5)
    for i in range(n):
        h.push(float(i), _frame(i))
    H, t = h.arrays()
    expect = np.arange(n - 5, n, dtype=float)
    np.testing.assert_allclose(t, expect)
    np.testing.assert_allclose(H[0][:, 0, 0], expect)
    np.testing.assert_allclose(H[3][:, 2, 1], -expect)
    latest, tl = h.latest()
    assert tl == n - 1 and latest[0][0, 0] == n - 1


def test_history_views_are_readonly_and_copies_are_independent():
    h = ElementHistory(maxlen=3)
    for i in range(4):
        h.push(float(i), _frame(i))
    H, _ = h.arrays(copy=False)
    with pytest.raises(ValueError):
        H[0][0, 0, 0] = 5.0
    Hc, _ = h.arrays()
    h.push(4.0, _frame(4))
    assert Hc[0][0, 0, 0] == 1.0


def test_history_rejects_bad_input():
    with pytest.raises(ConfigError):
        ElementHistory(0)
    h = ElementHistory(4)
    h.push(1.0, _frame(1))
    with pytest.raises(PerceptionError, match="differ"):
        h.push(2.0, {0: np.zeros((1, 3))})
    with pytest.raises(PerceptionError, match="backwards"):
        h.push(0.5, _frame(2))
    with pytest.raises(PerceptionError, match="shape"):
        h.push(2.0, {0: np.zeros((2, 3)), 3: np.zeros((4, 3))})
