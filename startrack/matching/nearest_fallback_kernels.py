"""Pair searches for the inputs the grid of :mod:`startrack.matching.nearest_kernels`
cannot take (an infinite or negative radius, infinite positions): a grid sized to the
observed and catalog extents with 3 x 3 cells scanned, and a strip over the catalog
sorted by x."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from startrack.database.sort_kernels import first_at_least

GRID_CELLS = 64  # cells per axis at most


@njit(cache=True)
def _grid(cx, cy, x0, y0, size, nx, ny):
    """Catalog positions bucketed in square cells: (cell start offsets, rows by cell)."""
    start = np.zeros(nx * ny + 1, np.int64)
    cell = np.empty(cx.shape[0], np.int64)
    for j in range(cx.shape[0]):
        cell[j] = int((cy[j] - y0) / size) * nx + int((cx[j] - x0) / size)
        start[cell[j] + 1] += 1
    for c in range(nx * ny):
        start[c + 1] += start[c]
    fill = start[:-1].copy()
    order = np.empty(cx.shape[0], np.int64)
    for j in range(cx.shape[0]):
        order[fill[cell[j]]] = j
        fill[cell[j]] += 1
    return start, order


@njit(cache=True)
def _nearest_cells(ox, oy, cx, cy, radius_px):
    """:func:`_nearest` over a grid of cells no smaller than the radius, the 3 x 3 cells
    around each star scanned."""
    n, m = ox.shape[0], cx.shape[0]
    nearest = np.full(n, -1, np.int64)
    dist2 = np.full(n, np.inf)
    if n == 0 or m == 0:
        return nearest, dist2
    x0, y0 = min(ox.min(), cx.min()), min(oy.min(), cy.min())
    x1, y1 = max(ox.max(), cx.max()), max(oy.max(), cy.max())
    # ~3 sqrt(n m) cells balance the cell scan against the pairs tested (filling a
    # fine grid cost more than the search); any size >= the radius finds the same pairs.
    cells = min(GRID_CELLS, max(1, int(math.sqrt(3.0 * math.sqrt(n * m)))))
    size = max(radius_px, (x1 - x0) / cells, (y1 - y0) / cells, 1e-9)
    nx, ny = int((x1 - x0) / size) + 1, int((y1 - y0) / size) + 1
    start, order = _grid(cx, cy, x0, y0, size, nx, ny)
    r2 = radius_px * radius_px
    for i in range(n):
        gx, gy = int((ox[i] - x0) / size), int((oy[i] - y0) / size)
        best, best_d = _best_in_cells(ox[i], oy[i], cx, cy, start, order, nx, max(gx - 1, 0),
                                      min(gx + 1, nx - 1), max(gy - 1, 0), min(gy + 1, ny - 1))
        if best >= 0 and best_d <= r2:
            nearest[i], dist2[i] = best, best_d
    return nearest, dist2


@njit(cache=True)
def _pairs_strip(ox, oy, x, y, radius2):
    """:func:`pairs_within` by an x strip a hair wider than the radius over the catalog
    sorted by x: any radius, infinite included."""
    n = len(ox)
    order = np.argsort(x)  # NaN last: never within any radius
    xs = x[order]
    finite = len(x)
    while finite > 0 and np.isnan(xs[finite - 1]):
        finite -= 1
    cap = n + 16
    e_obs = np.empty(cap, np.int64)
    e_cat = np.empty(cap, np.int64)
    e_d2 = np.empty(cap)
    start = np.zeros(n + 1, np.int64)
    count = 0
    half = math.sqrt(radius2) * (1.0 + 1e-9) + 1e-9 if radius2 >= 0.0 else -1.0
    for i in range(n):
        start[i] = count
        if half < 0.0 or np.isnan(ox[i]) or np.isnan(oy[i]):
            continue
        pad = half + 1e-12 * abs(ox[i])
        for s in range(first_at_least(xs, 0, finite, ox[i] - pad), finite):
            if xs[s] > ox[i] + pad:
                break
            j = order[s]
            dx, dy = ox[i] - x[j], oy[i] - y[j]
            d2 = dx * dx + dy * dy
            if not d2 <= radius2:
                continue
            if count == cap:
                cap *= 2
                e_obs, e_cat, e_d2 = _grow(e_obs, cap), _grow(e_cat, cap), _grow(e_d2, cap)
            insert_pair(e_obs, e_cat, e_d2, start[i], count, i, j, d2)
            count += 1
    start[n] = count
    return e_obs[:count], e_cat[:count], e_d2[:count], start


@njit(cache=True)
def _grow(a, cap):
    out = np.empty(cap, a.dtype)
    out[:a.shape[0]] = a
    return out


@njit(cache=True)
def _best_in_cells(x, y, cx, cy, start, order, nx, gx0, gx1, gy0, gy1):
    """The catalog star nearest (x, y) among grid cells gx0..gx1 x gy0..gy1 (on a tie the
    lower index; -1 if none) and its squared distance."""
    best, best_d = -1, np.inf
    for yy in range(gy0, gy1 + 1):
        for xx in range(gx0, gx1 + 1):
            c = yy * nx + xx
            for q in range(start[c], start[c + 1]):
                j = order[q]
                d = (x - cx[j]) ** 2 + (y - cy[j]) ** 2
                if d < best_d or (d == best_d and j < best):
                    best, best_d = j, d
    return best, best_d


@njit(cache=True)
def insert_pair(e_obs, e_cat, e_d2, first, count, i, j, d2):
    """Pair (i, j, d2) written at position ``count``, moved down past the pairs of the
    same observed star (from ``first`` on) with a higher catalog index: a star has few
    pairs, so insertion keeps each star's pairs sorted by catalog index."""
    k = count
    while k > first and e_cat[k - 1] > j:
        e_obs[k], e_cat[k], e_d2[k] = e_obs[k - 1], e_cat[k - 1], e_d2[k - 1]
        k -= 1
    e_obs[k], e_cat[k], e_d2[k] = i, j, d2
