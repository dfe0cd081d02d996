"""The compiled core's shared routines (sorted-range search, Wahba, order statistics)
held to numpy and scipy."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from startrack._core import shared


def test_first_at_least_is_searchsorted_left():
    rng = np.random.default_rng(1)
    values = np.sort(rng.integers(0, 50, 200).astype(float))
    for x in rng.uniform(-5, 55, 100):
        assert shared.first_at_least(values, 0, len(values), x) == np.searchsorted(values, x)
    assert shared.first_at_least(values, 10, 20, 1e9) == 20


def test_kvector_range_matches_a_mask():
    rng = np.random.default_rng(2)
    values = np.sort(rng.uniform(0, 1, 500))
    n = len(values)
    m = (values[-1] - values[0]) / (n - 1)
    q = values[0] - m / 2
    kk = np.searchsorted(values, m * np.arange(n) + q, side="right").astype(np.int64)
    for lo in rng.uniform(-0.1, 1.1, 50):
        hi = lo + rng.uniform(0, 0.2)
        start, stop = shared.kvector_range(values, kk, m, q, lo, hi)
        inside = np.flatnonzero((values >= lo) & (values <= hi))
        assert (start, stop) == ((inside[0], inside[-1] + 1) if len(inside) else (start, start))
    assert shared.kvector_range(values, kk, m, q, np.nan, 1.0) == (0, 0)


def test_wahba_recovers_a_rotation_and_quaternion_matches_scipy():
    rng = np.random.default_rng(3)
    truth = Rotation.random(random_state=4)
    cam = rng.normal(size=(12, 3))
    cam /= np.linalg.norm(cam, axis=1)[:, None]
    sky = truth.apply(cam)
    r = shared.wahba(cam, sky)
    assert np.allclose(r, truth.as_matrix(), atol=1e-12)
    q = shared.matrix_to_quaternion(r)
    expected = truth.as_quat()
    expected = expected if expected[3] >= 0 else -expected
    assert np.allclose(q, expected, atol=1e-12)
    assert q[3] >= 0


@pytest.mark.parametrize("n", [0, 1, 2, 7, 8, 301])
def test_median_and_ptp_are_numpys(n):
    values = np.random.default_rng(n).normal(size=n)
    expected = np.median(values) if n else np.nan
    assert shared.median(values) == expected or (n == 0 and np.isnan(shared.median(values)))
    if n:
        assert shared.ptp(values) == np.ptp(values)
        values[n // 2] = np.nan
        assert np.isnan(shared.median(values)) and np.isnan(shared.ptp(values))
