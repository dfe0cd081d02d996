"""The timing loop the micro-benchmarks share: the median of repeated calls."""

from __future__ import annotations

import time

import numpy as np


def median_us(call, repeats: int) -> float:
    """The median of ``repeats`` timed calls of ``call``, in microseconds, after one untimed
    call (a first call's one-time costs are never timed)."""
    call()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        call()
        times.append(time.perf_counter() - t0)
    return float(np.median(times)) * 1e6
