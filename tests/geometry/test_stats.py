"""The painter's order statistics equal numpy's to the last bit (they exist only to skip numpy's call overhead)."""

from __future__ import annotations

import numpy as np

from code_as_monitor.geometry.stats import median, percentile


def _samples(rng: np.random.Generator) -> list[np.ndarray]:
    out = [np.array([0.3]), np.array([1.0, 1.0]), np.array([2.0, -1.0])]
    for n in [*range(2, 40), 97, 256, 1001, 2048]:
        out.append(rng.normal(0.0, rng.uniform(1e-4, 10.0), n))
        out.append(np.round(rng.uniform(-1, 1, n), 2))  # ties
    return out


def test_percentile_equals_numpy_bit_for_bit() -> None:
    rng = np.random.default_rng(3)
    qs = [0.0, 1.0, 2.0, 5.0, 25.0, 50.0, 95.0, 98.0, 99.0, 100.0, 33.3, 66.7, 99.99]
    for x in _samples(rng):
        for q in qs:
            got, want = percentile(x, q), np.percentile(x, q)
            assert isinstance(got, np.floating) and got == want and got.dtype == want.dtype, (len(x), q, got, want)
        for pair in ([5.0, 95.0], [2.0, 98.0], [1.0, 50.0, 99.0]):
            np.testing.assert_array_equal(percentile(x, pair), np.percentile(x, pair))
    for n in (1, 2, 7, 300):  # per column, as the part cloud's extent takes it
        P = rng.normal(0.0, 0.05, (n, 3))
        np.testing.assert_array_equal(percentile(P, [2.0, 98.0], axis=0), np.percentile(P, [2.0, 98.0], axis=0))


def test_median_equals_numpy_bit_for_bit() -> None:
    rng = np.random.default_rng(4)
    for x in _samples(rng):
        assert median(x) == float(np.median(x)), len(x)


def test_what_is_not_a_finite_float_array_goes_to_numpy() -> None:
    x = np.array([1.0, np.nan, 3.0])
    assert np.isnan(percentile(x, 50.0)) and np.isnan(median(x))
    assert percentile(np.arange(10), 95.0) == np.percentile(np.arange(10), 95.0)  # integers
    assert median(np.array([3, 1, 2])) == 2.0
