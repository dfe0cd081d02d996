"""The numba cone lookup the numba verification kernels still call (moved here from
startrack.database.cone, which now calls the compiled one); it goes with them once
tracking calls the compiled verification."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from startrack.database.cone import BAND_RAD, EDGE
from startrack.database.sort_kernels import first_at_least


@njit(cache=True)
def _windows(ra_sorted, band_start, direction, radius):
    """The (start, stop) positions of ``order`` that can hold the cone's stars: per band
    the RA window of the cone (two pieces where it wraps through RA 0)."""
    n_bands = band_start.shape[0] - 1
    dec = math.asin(max(-1.0, min(1.0, direction[2])))
    ra = math.atan2(direction[1], direction[0]) % (2.0 * math.pi)
    b0 = max(int((dec - radius + math.pi / 2.0) / BAND_RAD - EDGE), 0)
    b1 = min(int((dec + radius + math.pi / 2.0) / BAND_RAD + EDGE), n_bands - 1)
    # The widest RA offset of any point of the cone; all of it when a pole is inside.
    half = math.pi
    if abs(dec) + radius < math.pi / 2.0 - EDGE and radius < math.pi / 2.0:
        half = math.asin(min(1.0, math.sin(radius) / math.cos(dec))) + EDGE
    spans = np.empty((2 * max(b1 - b0 + 1, 0), 2), np.int64)
    n = 0
    for b in range(b0, b1 + 1):
        lo, hi = band_start[b], band_start[b + 1]
        a, z = ra - half, ra + half
        if half >= math.pi:
            a, z = 0.0, 2.0 * math.pi
        elif a < 0.0:  # the window wraps through RA 0: two pieces
            spans[n, 0], spans[n, 1] = first_at_least(ra_sorted, lo, hi, a + 2.0 * math.pi), hi
            n += 1
            a = 0.0
        elif z >= 2.0 * math.pi:
            spans[n, 0] = lo
            spans[n, 1] = first_at_least(ra_sorted, lo, hi, z - 2.0 * math.pi + EDGE)
            n += 1
            z = 2.0 * math.pi
        s0 = first_at_least(ra_sorted, lo, hi, a)
        spans[n, 0], spans[n, 1] = s0, first_at_least(ra_sorted, s0, hi, z + EDGE)
        n += 1
    return spans[:n]


@njit(cache=True)
def cone_rows(vectors, order, ra_sorted, band_start, direction, radius):
    """Rows of ``vectors`` within ``radius`` of ``direction``, ascending. ``order`` lists
    the rows band by band (``band_start``: each band's first position), by right
    ascension within a band (``ra_sorted``, in [0, 2 pi))."""
    spans = _windows(ra_sorted, band_start, direction, radius)
    size = 0
    for w in range(spans.shape[0]):
        size += spans[w, 1] - spans[w, 0]
    cos_radius = math.cos(radius)
    dx, dy, dz = direction[0], direction[1], direction[2]
    out = np.empty(size, np.int64)
    k = 0
    for w in range(spans.shape[0]):
        for s in range(spans[w, 0], spans[w, 1]):
            row = order[s]
            if vectors[row, 0] * dx + vectors[row, 1] * dy + vectors[row, 2] * dz \
                    >= cos_radius:
                out[k] = row
                k += 1
    return np.sort(out[:k])


