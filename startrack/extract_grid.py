"""Compiled clean-up of the centroider's tile grid: spikes replaced, then smoothed.

The tile grid is small (a value per ~31 x 31 pixels) but its clean-up runs four times per
frame, so it is compiled too: numpy's nan-aware medians over 3 x 3 windows cost more
than the whole pixel pass.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

_MAD_TO_SIGMA = 1.4826


@njit(cache=True, nogil=True)
def _pad_odd(grid):
    """``np.pad(grid, 1, mode="reflect", reflect_type="odd")``: planes extend as planes."""
    n_r, n_c = grid.shape
    p = np.empty((n_r + 2, n_c + 2))
    p[1:-1, 1:-1] = grid
    p[0, 1:-1] = 2.0 * grid[0] - grid[1]
    p[-1, 1:-1] = 2.0 * grid[-1] - grid[-2]
    p[:, 0] = 2.0 * p[:, 1] - p[:, 2]
    p[:, -1] = 2.0 * p[:, -2] - p[:, -3]
    return p


@njit(cache=True, nogil=True)
def _nanmedian(values):
    finite = values[~np.isnan(values)]
    return np.median(finite) if len(finite) else np.nan


@njit(cache=True, nogil=True)
def _two(a, b):
    """(a, b) in order."""
    return min(a, b), max(a, b)


@njit(cache=True, nogil=True)
def _window_median(p, i, j, buf):
    """NaN-aware median of the 3 x 3 window ``p[i:i+3, j:j+3]``: as ``_nanmedian``
    without an allocation per tile. Nine numbers go through a median network (min and max,
    no branch; of a tie between 0.0 and -0.0 either may come out, as from any sort); a
    window with a NaN is sorted in ``buf``."""
    v0, v1, v2 = p[i, j], p[i, j + 1], p[i, j + 2]
    v3, v4, v5 = p[i + 1, j], p[i + 1, j + 1], p[i + 1, j + 2]
    v6, v7, v8 = p[i + 2, j], p[i + 2, j + 1], p[i + 2, j + 2]
    if not np.isnan(v0 + v1 + v2 + v3 + v4 + v5 + v6 + v7 + v8):  # none is NaN
        # Paeth's median-of-9 network (19 exchanges), each exchange a min and a max
        (v1, v2), (v4, v5), (v7, v8) = _two(v1, v2), _two(v4, v5), _two(v7, v8)
        (v0, v1), (v3, v4), (v6, v7) = _two(v0, v1), _two(v3, v4), _two(v6, v7)
        (v1, v2), (v4, v5), (v7, v8) = _two(v1, v2), _two(v4, v5), _two(v7, v8)
        (v0, v3), (v5, v8), (v4, v7) = _two(v0, v3), _two(v5, v8), _two(v4, v7)
        (v3, v6), (v1, v4), (v2, v5) = _two(v3, v6), _two(v1, v4), _two(v2, v5)
        v4, v7 = _two(v4, v7)
        v4, v2 = _two(v4, v2)
        v6, v4 = _two(v6, v4)
        v4, v2 = _two(v4, v2)
        return v4
    n = 0
    for di in range(3):
        for dj in range(3):
            v = p[i + di, j + dj]
            if not np.isnan(v):
                k = n
                while k > 0 and buf[k - 1] > v:
                    buf[k] = buf[k - 1]
                    k -= 1
                buf[k] = v
                n += 1
    if n == 0:
        return np.nan
    return buf[n // 2] if n % 2 else 0.5 * (buf[n // 2 - 1] + buf[n // 2])


@njit(cache=True, nogil=True)
def _despike(grid):
    """Replace tiles that stand out from their 3x3 neighbourhood (or are NaN) by its median.

    Only outliers are replaced: a median filter over the whole grid would also erase the
    tile-to-tile corrections that the second background pass exists to make.
    """
    n_r, n_c = grid.shape
    p = _pad_odd(grid)
    local, buf = np.empty_like(grid), np.empty(9)
    for i in range(n_r):
        for j in range(n_c):
            local[i, j] = _window_median(p, i, j, buf)
    deviation = np.abs(grid - local)
    if np.isnan(deviation).all():
        return local
    spread = _MAD_TO_SIGMA * _nanmedian(deviation.ravel())
    out = grid.copy()
    for i in range(n_r):
        for j in range(n_c):
            if np.isnan(grid[i, j]) or deviation[i, j] > 3.0 * spread:
                out[i, j] = local[i, j]
    return out


@njit(cache=True, nogil=True)
def clean_grid(grid, average, fallback):
    """Tiles spoiled by a bright star replaced from their neighbours; with ``average`` the
    grid is then smoothed by a 3x3 mean (planes pass unchanged). NaN tiles left over take
    the grid's median (``fallback`` when every tile is NaN)."""
    n_r, n_c = grid.shape
    if n_r >= 3 and n_c >= 3:
        grid = _despike(grid)
        if average and not np.isnan(grid).any():
            p = _pad_odd(grid)
            for i in range(n_r):
                for j in range(n_c):
                    grid[i, j] = p[i:i + 3, j:j + 3].sum() / 9.0
    else:
        grid = grid.copy()
    if np.isnan(grid).any():
        value = _nanmedian(grid.ravel())
        if math.isnan(value):
            value = fallback
        for i in range(n_r):
            for j in range(n_c):
                if np.isnan(grid[i, j]):
                    grid[i, j] = value
    return grid
