"""The k-vector answers every range query exactly as a binary search on the sorted values."""

from __future__ import annotations

import numpy as np
import pytest

from startrack.database._kvector import KVector, binary_search_range


def _arrays() -> dict[str, np.ndarray]:
    rng = np.random.default_rng(20240501)
    clustered = np.concatenate([rng.normal(0.1, 1e-4, 400), rng.normal(0.3, 1e-6, 300),
                                rng.uniform(0.0, 0.5, 50)])
    return {
        "empty": np.zeros(0),
        "one": np.array([0.25]),
        "two": np.array([0.1, 0.4]),
        "two-equal": np.array([0.2, 0.2]),
        "uniform": np.sort(rng.uniform(0.0, 0.5, 2000)),
        "clustered": np.sort(clustered),
        "duplicates": np.sort(rng.integers(0, 20, 1000).astype(np.float64) * 0.01),
        "all-equal": np.full(100, 0.3),
        "negative": np.sort(rng.normal(-5.0, 2.0, 500)),
        "steps": np.repeat(np.linspace(0.0, 1.0, 11), 7),
    }


ARRAYS = _arrays()


def _queries(values: np.ndarray, rng: np.random.Generator, count: int) -> np.ndarray:
    """Query bounds inside, across and outside the range, and on the stored values."""
    lo_end = values.min() if len(values) else 0.0
    hi_end = values.max() if len(values) else 1.0
    span = max(hi_end - lo_end, 1e-3)
    points = [rng.uniform(lo_end - 0.5 * span, hi_end + 0.5 * span, count)]
    if len(values):
        points.append(rng.choice(values, count))  # bounds exactly on stored values
        points.append(rng.choice(values, count) + rng.normal(0.0, 1e-12, count))
    return np.concatenate(points)


@pytest.mark.parametrize("name", sorted(ARRAYS))
def test_range_matches_binary_search(name):
    values = ARRAYS[name]
    kv = KVector.build(values)
    rng = np.random.default_rng(7)
    lows = _queries(values, rng, 300)
    widths = np.concatenate([np.zeros(len(lows) // 3),
                             rng.exponential(0.01, len(lows) - len(lows) // 3)])
    rng.shuffle(widths)
    for lo, width in zip(lows, widths, strict=True):
        hi = lo + width
        assert kv.range(lo, hi) == binary_search_range(values, lo, hi), (name, lo, hi)


@pytest.mark.parametrize("name", ["uniform", "clustered", "duplicates"])
def test_queries_on_the_kvector_grid(name):
    """Bounds exactly on the k-vector's line z(i) = m*i + q, where rounding could bite."""
    values = ARRAYS[name]
    kv = KVector.build(values)
    grid = kv.m * np.arange(len(values)) + kv.q
    for lo in grid[::7]:
        for hi in (lo, lo + kv.m, lo + 3.5 * kv.m):
            assert kv.range(lo, hi) == binary_search_range(values, lo, hi), (name, lo, hi)


def test_whole_range_and_outside():
    values = ARRAYS["uniform"]
    kv = KVector.build(values)
    assert kv.range(-1.0, 2.0) == (0, len(values))
    assert kv.range(-2.0, -1.0) == (0, 0)
    assert kv.range(1.0, 2.0) == (len(values), len(values))


def test_inverted_query_is_empty():
    kv = KVector.build(ARRAYS["uniform"])
    start, stop = kv.range(0.3, 0.2)
    assert stop - start == 0


def test_build_rejects_unsorted_and_non_1d():
    with pytest.raises(ValueError, match="sorted"):
        KVector.build(np.array([0.1, 0.3, 0.2]))
    with pytest.raises(ValueError, match="1-D"):
        KVector.build(np.zeros((3, 2)))


def test_k_counts_values_below_the_line():
    values = ARRAYS["clustered"]
    kv = KVector.build(values)
    z = kv.m * np.arange(len(values)) + kv.q
    np.testing.assert_array_equal(kv.k, [np.count_nonzero(values <= zi) for zi in z])
    assert kv.k[0] == 0 and kv.k[-1] == len(values)
