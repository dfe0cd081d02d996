"""Compiled pairing of observed and projected catalog positions: the nearest star, and
every pair within a radius, on a grid of about one catalog star per cell, so that a frame
of hundreds of stars costs O(n + m) and not O(n m) (no sort, no bisection)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from startrack.matching.nearest_fallback_kernels import (
    _best_in_cells,
    _nearest_cells,
    _pairs_strip,
    insert_pair,
)


@njit(cache=True)
def _nearest(ox, oy, cx, cy, radius_px):
    """Per observed star, its nearest catalog star if within ``radius_px`` (else -1; on a
    tie the lower index) and the squared distance. The catalog grid of
    :func:`_catalog_grid`; each star scans only the cells its radius reaches. A negative
    or infinite radius, or infinite catalog positions, take :func:`_nearest_cells`."""
    n = ox.shape[0]
    if not (0.0 <= radius_px < np.inf and n > 0):
        return _nearest_cells(ox, oy, cx, cy, radius_px)
    half = radius_px * (1.0 + 1e-9) + 1e-9
    ok, start, order, grid = _catalog_grid(cx, cy, half)
    if not ok:
        return _nearest_cells(ox, oy, cx, cy, radius_px)
    nearest = np.full(n, -1, np.int64)
    dist2 = np.full(n, np.inf)
    x0, y0, size, nx, ny = grid
    r2 = radius_px * radius_px
    for i in range(n):
        if np.isnan(ox[i]) or np.isnan(oy[i]):
            continue
        pad = half + 1e-12 * max(abs(ox[i]), abs(oy[i]))
        gx0, gx1 = _cell_span(ox[i], pad, x0, size, nx)
        gy0, gy1 = _cell_span(oy[i], pad, y0, size, ny)
        best, best_d = _best_in_cells(ox[i], oy[i], cx, cy, start, order, nx, gx0, gx1,
                                      gy0, gy1)
        if best >= 0 and best_d <= r2:
            nearest[i], dist2[i] = best, best_d
    return nearest, dist2


@njit(cache=True)
def nearest_matches(ox, oy, cx, cy, radius_px):
    """Pair each observed star (ox, oy) with its nearest catalog star (cx, cy) within
    ``radius_px``; a catalog star claimed by several keeps the nearest (on a tie, the
    first). Returns (observed rows ascending, catalog positions)."""
    nearest, dist2 = _nearest(ox, oy, cx, cy, radius_px)
    owner = np.full(cx.shape[0], -1, np.int64)
    for i in range(ox.shape[0]):
        j = nearest[i]
        if j >= 0 and (owner[j] < 0 or dist2[i] < dist2[owner[j]]):
            owner[j] = i
    keep = np.zeros(ox.shape[0], np.bool_)
    for i in range(ox.shape[0]):
        keep[i] = nearest[i] >= 0 and owner[nearest[i]] == i
    rows = np.flatnonzero(keep)
    return rows, nearest[rows]


@njit(cache=True)
def pairs_within(ox, oy, x, y, radius2):
    """Every pair of an observed star (ox, oy) and a catalog star (x, y) whose squared
    distance is <= ``radius2``, sorted by observed then catalog index: (observed, catalog,
    squared distance, per observed star the start of its pairs; n + 1 offsets). A NaN
    position pairs with nothing.

    The catalog is bucketed in a grid of about one star per cell, cells no smaller than
    the radius, and each observed star scans the cells its radius, a hair widened so that
    rounding cannot drop a pair the exact test keeps, reaches (no sort, no bisection: a
    frame pays a few hundred cell visits). An infinite radius, or a catalog with infinite
    positions, takes the strip search (:func:`_pairs_strip`)."""
    n, m = len(ox), len(x)
    if not radius2 < np.inf or m == 0 or n == 0:
        return _pairs_strip(ox, oy, x, y, radius2)
    half = math.sqrt(radius2) * (1.0 + 1e-9) + 1e-9 if radius2 >= 0.0 else -1.0
    ok, start_c, order, grid = _catalog_grid(x, y, max(half, 0.0))
    if not ok:
        return _pairs_strip(ox, oy, x, y, radius2)
    cap = n + 16
    while True:  # a second pass only when the first guess of the pair count was short
        e_obs = np.empty(cap, np.int64)
        e_cat = np.empty(cap, np.int64)
        e_d2 = np.empty(cap)
        start = np.zeros(n + 1, np.int64)
        count = _scan_cells(ox, oy, x, y, radius2, half, grid, start_c, order, e_obs, e_cat,
                            e_d2, start)
        if count <= cap:
            return e_obs[:count], e_cat[:count], e_d2[:count], start
        cap = count


@njit(cache=True)
def _catalog_grid(x, y, half):
    """The finite catalog positions in a grid of about one per cell, cells no smaller
    than ``half``: (usable, cell start offsets, positions by cell, (x0, y0, cell size,
    cells along x, along y)). Not usable with an infinite position, or extents that
    overflow or hold no position."""
    m = x.shape[0]
    finite = np.empty(m, np.bool_)
    x0, y0, x1, y1 = np.inf, np.inf, -np.inf, -np.inf
    bad = False
    for j in range(m):
        finite[j] = math.isfinite(x[j]) and math.isfinite(y[j])
        if finite[j]:
            x0, x1, y0, y1 = min(x0, x[j]), max(x1, x[j]), min(y0, y[j]), max(y1, y[j])
        elif not (math.isnan(x[j]) or math.isnan(y[j])):
            bad = True  # inf - inf would be NaN in the extents
    none = np.zeros(1, np.int64)
    if bad or not (0.0 <= x1 - x0 < np.inf and 0.0 <= y1 - y0 < np.inf):
        return False, none, none, (0.0, 0.0, 1.0, 1, 1)
    cells = max(1, int(math.sqrt(m)))
    size = max(half, (x1 - x0) / cells, (y1 - y0) / cells, 1e-9)
    nx = int(min((x1 - x0) / size, cells)) + 1
    ny = int(min((y1 - y0) / size, cells)) + 1
    start, order = _grid_finite(x, y, finite, x0, y0, size, nx, ny)
    return True, start, order, (x0, y0, size, nx, ny)


@njit(cache=True)
def _scan_cells(ox, oy, x, y, radius2, half, grid, start_c, order, e_obs, e_cat, e_d2,
                start):
    """:func:`pairs_within`'s pairs written into the given arrays (insertion by catalog
    index: a star has few pairs); returns how many there are, which may exceed the
    arrays (then only the count is right). Arrays are never reassigned here, which
    keeps numba's reference counting out of the loop."""
    x0, y0, size, nx, ny = grid
    cap, count, n = e_obs.shape[0], 0, ox.shape[0]
    for i in range(n):
        start[i] = count
        if half < 0.0 or np.isnan(ox[i]) or np.isnan(oy[i]):
            continue
        pad = half + 1e-12 * max(abs(ox[i]), abs(oy[i]))
        gx0, gx1 = _cell_span(ox[i], pad, x0, size, nx)
        gy0, gy1 = _cell_span(oy[i], pad, y0, size, ny)
        for gy in range(gy0, gy1 + 1):
            for gx in range(gx0, gx1 + 1):
                c = gy * nx + gx
                for q in range(start_c[c], start_c[c + 1]):
                    j = order[q]
                    dx, dy = ox[i] - x[j], oy[i] - y[j]
                    d2 = dx * dx + dy * dy
                    if not d2 <= radius2:
                        continue
                    if count < cap:
                        insert_pair(e_obs, e_cat, e_d2, start[i], count, i, j, d2)
                    count += 1
    start[n] = count
    return count


@njit(cache=True)
def _cell_span(v, pad, v0, size, cells):
    """The first and last grid cell along one axis that [v - pad, v + pad] reaches
    (clipped to the grid; last < first when it misses it)."""
    lo = (v - pad - v0) / size
    hi = (v + pad - v0) / size
    if not hi >= 0.0 or not lo < cells:
        return 0, -1
    return int(max(lo, 0.0)), int(min(hi, cells - 1.0))


@njit(cache=True)
def _grid_finite(x, y, finite, x0, y0, size, nx, ny):
    """The finite positions bucketed in square cells (a counting sort, stable): (cell
    start offsets, positions by cell)."""
    start = np.zeros(nx * ny + 1, np.int64)
    cell = np.full(x.shape[0], -1, np.int64)
    for j in range(x.shape[0]):
        if finite[j]:
            gx = min(int((x[j] - x0) / size), nx - 1)
            gy = min(int((y[j] - y0) / size), ny - 1)
            cell[j] = gy * nx + gx
            start[cell[j] + 1] += 1
    for c in range(nx * ny):
        start[c + 1] += start[c]
    fill = start[:-1].copy()
    order = np.empty(start[nx * ny], np.int64)
    for j in range(x.shape[0]):
        if cell[j] >= 0:
            order[fill[cell[j]]] = j
            fill[cell[j]] += 1
    return start, order


