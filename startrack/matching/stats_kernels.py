"""Compiled order statistics with numpy's semantics (NaN in, NaN out), for the kernels
that fit a scatter to a frame's few hundred values."""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def median(values):
    """numpy's median: NaN for no value or any NaN, the middle two averaged. By
    selection (``np.partition``), not a full sort: the same order statistics, in O(n)."""
    n = len(values)
    if n == 0:
        return np.nan
    for v in values:
        if np.isnan(v):
            return np.nan
    s = np.partition(values, n // 2)
    upper = s[n // 2]
    if n % 2:
        return upper
    return (s[:n // 2].max() + upper) / 2.0


@njit(cache=True)
def ptp(values):
    """numpy's ptp of a non-empty array (max - min): NaN if any value is NaN."""
    lo, hi = values[0], values[0]
    for v in values:
        if np.isnan(v):
            return np.nan
        lo, hi = min(lo, v), max(hi, v)
    return hi - lo
