"""frames.pack / unpack: one frame on the wire round-trips exactly, read-only, and bad shapes are named."""

from __future__ import annotations

import numpy as np
import pytest

from code_as_monitor.core.errors import ShapeMismatchError
from code_as_monitor.monitor.frames import pack, unpack


def _frame(rng: np.random.Generator, T: int = 7) -> tuple[dict, dict, np.ndarray]:
    ks = {0: 1, 3: 2, 5: 4, 9: 5}
    E = {i: rng.normal(size=(k, 3)) for i, k in ks.items()}
    H = {i: rng.normal(size=(T, k, 3)) for i, k in ks.items()}
    return E, H, np.linspace(0.0, 1.0, T)


def test_round_trip_with_history_is_exact() -> None:
    E, H, Ht = _frame(np.random.default_rng(3))
    le, lh, data = pack(E, H, Ht, 1.0)
    assert len(data) == 8 * (sum(p.size for p in E.values()) + sum(h.size for h in H.values()) + Ht.size)
    E2, H2, Ht2 = unpack(le, lh, data)
    assert list(E2) == list(E) and list(H2) == list(H)
    for i in E:
        np.testing.assert_array_equal(E2[i], E[i])
        np.testing.assert_array_equal(H2[i], H[i])
        assert not E2[i].flags.writeable and not H2[i].flags.writeable
    np.testing.assert_array_equal(Ht2, Ht)


def test_without_history_each_element_is_its_own_one_frame_history() -> None:
    E = {2: [0.1, 0.2, 0.3], 4: np.arange(6, dtype=np.int64).reshape(2, 3)}  # a bare point, an int array
    le, lh, data = pack(E, None, None, 2.5)
    assert le == ((2, 1), (4, 2)) and lh == ((2, 1, 1), (4, 1, 2))
    E2, H2, Ht2 = unpack(le, lh, data)
    np.testing.assert_array_equal(E2[2], [[0.1, 0.2, 0.3]])
    np.testing.assert_array_equal(H2[4][0], np.arange(6.0).reshape(2, 3))
    np.testing.assert_array_equal(Ht2, [2.5])


def test_non_contiguous_inputs_are_packed_by_value() -> None:
    big = np.random.default_rng(1).normal(size=(6, 6))
    E = {0: big[::2, 1:4]}  # a strided view, (3, 3)
    _, _, data = pack(E, None, None, 0.0)
    np.testing.assert_array_equal(np.frombuffer(data, dtype=np.float64)[:9], big[::2, 1:4].ravel())


@pytest.mark.parametrize("bad", [np.zeros((2, 2)), np.zeros((1, 2, 3)), np.zeros(4)])
def test_bad_element_shape_names_the_element_and_shape(bad: np.ndarray) -> None:
    with pytest.raises(ShapeMismatchError, match=rf"element 7: .*{bad.shape}".replace("(", r"\(").replace(")", r"\)")):
        pack({7: bad}, None, None, 0.0)


def test_bad_history_shape_names_the_element_and_expected_length() -> None:
    E, H, Ht = _frame(np.random.default_rng(0))
    H[5] = H[5][:-1]
    with pytest.raises(ShapeMismatchError, match=r"history of element 5 must be \(T=7"):
        pack(E, H, Ht, 0.0)
