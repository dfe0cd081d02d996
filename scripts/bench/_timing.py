"""The timing loop the micro-benchmarks share: the median of repeated calls."""

from __future__ import annotations

import statistics
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


def wall_cpu_ms(call, repeats: int) -> tuple[float, float]:
    """Median wall and CPU milliseconds of ``repeats`` calls of ``call``, after one untimed
    call (imports, compiled kernels, the allocator)."""
    call()
    wall, cpu = [], []
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        call()
        wall.append((time.perf_counter() - t0) * 1e3)
        cpu.append((time.process_time() - c0) * 1e3)
    return statistics.median(wall), statistics.median(cpu)
