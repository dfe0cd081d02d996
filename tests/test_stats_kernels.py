"""The compiled order statistics against numpy's own, NaN and ties included."""

from __future__ import annotations

import numpy as np

from startrack.matching.stats_kernels import median, ptp


def test_median_and_ptp_are_numpys():
    rng = np.random.default_rng(31)
    for t in range(2000):
        n = int(rng.integers(1, 40))
        values = rng.normal(size=n)
        if t % 3 == 0:
            values = np.round(values * 2.0) / 2.0  # ties
        if t % 5 == 0:
            values[rng.integers(n)] = rng.choice([np.inf, -np.inf])
        if t % 7 == 0:
            values[rng.integers(n)] = np.nan
        with np.errstate(invalid="ignore"):  # inf - inf: NaN, on both sides
            want_median, want_ptp = np.median(values), np.ptp(values)
        got, want = median(values), want_median
        assert got == want or (np.isnan(got) and np.isnan(want))
        got, want = ptp(values), want_ptp
        assert got == want or (np.isnan(got) and np.isnan(want))
    assert np.isnan(median(np.zeros(0)))
