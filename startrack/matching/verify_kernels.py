"""Compiled arithmetic of verification: observed stars paired with projected catalog
stars, nearest first, each catalog star at most once."""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def nearest_matches(ox, oy, cx, cy, radius_px):
    """Pair each observed star (ox, oy) with its nearest catalog star (cx, cy) within
    ``radius_px``; a catalog star claimed by several keeps the nearest (on a tie, the
    first). Returns (observed rows ascending, catalog positions)."""
    n, m = len(ox), len(cx)
    nearest = np.full(n, -1, np.int64)
    dist2 = np.empty(n)
    r2 = radius_px * radius_px
    for i in range(n):
        best, best_d = -1, np.inf
        for j in range(m):
            d = (ox[i] - cx[j]) ** 2 + (oy[i] - cy[j]) ** 2
            if d < best_d:
                best, best_d = j, d
        if best_d <= r2:
            nearest[i], dist2[i] = best, best_d
    owner = np.full(m, -1, np.int64)
    for i in range(n):
        j = nearest[i]
        if j >= 0 and (owner[j] < 0 or dist2[i] < dist2[owner[j]]):
            owner[j] = i
    keep = np.zeros(n, np.bool_)
    for i in range(n):
        keep[i] = nearest[i] >= 0 and owner[nearest[i]] == i
    rows = np.flatnonzero(keep)
    return rows, nearest[rows]
