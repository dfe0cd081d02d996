"""The centroider's tile grid cleaned (spikes replaced, then smoothed), and the exact
medians of its sky model for Python (tile medians, noise MADs; ``_median``).

The tile grid is small (a value per ~31 x 31 pixels) but its clean-up runs four times per
frame: numpy's nan-aware medians over 3 x 3 windows would cost more than the pixel pass.
"""

import numpy as np

from libc.math cimport NAN, fabs, isnan

from startrack._core.centroids.median cimport mad as _mad, median_copy, middle as _middle
from startrack._core._stats cimport median_inplace

cdef double MAD_TO_SIGMA = 1.4826


cdef double[:, ::1] _pad_odd(const double[:, ::1] grid):
    """``np.pad(grid, 1, mode="reflect", reflect_type="odd")``: planes extend as planes."""
    cdef Py_ssize_t n_r = grid.shape[0], n_c = grid.shape[1], i, j
    cdef double[:, ::1] p = np.empty((n_r + 2, n_c + 2))
    for i in range(n_r):
        for j in range(n_c):
            p[i + 1, j + 1] = grid[i, j]
    for j in range(n_c):
        p[0, j + 1] = 2.0 * grid[0, j] - grid[1, j]
        p[n_r + 1, j + 1] = 2.0 * grid[n_r - 1, j] - grid[n_r - 2, j]
    for i in range(n_r + 2):
        p[i, 0] = 2.0 * p[i, 1] - p[i, 2]
        p[i, n_c + 1] = 2.0 * p[i, n_c] - p[i, n_c - 1]
    return p


cdef double _nanmedian(const double[:, ::1] values):
    """np.median of the values that are not NaN (NaN if none)."""
    cdef double[::1] finite = np.empty(values.shape[0] * values.shape[1])
    cdef Py_ssize_t n = 0, i, j
    for i in range(values.shape[0]):
        for j in range(values.shape[1]):
            if not isnan(values[i, j]):
                finite[n] = values[i, j]
                n += 1
    return median_inplace(finite[:n])


cdef inline void _order(double* a, double* b) noexcept nogil:
    """(a, b) put in order: the min and max of Python (the first of a tie stays first)."""
    cdef double lo = min(a[0], b[0]), hi = max(a[0], b[0])
    a[0] = lo
    b[0] = hi


cdef double _window_median(const double[:, ::1] p, Py_ssize_t i, Py_ssize_t j,
                           double[::1] buf) noexcept nogil:
    """NaN-aware median of the 3 x 3 window ``p[i:i+3, j:j+3]`` without an allocation:
    nine numbers through Paeth's median network (19 exchanges, each a min and a max; of a
    tie between 0.0 and -0.0 either may come out, as from any sort); a window with a NaN
    is sorted in ``buf``."""
    cdef double v[9]
    cdef double x
    cdef Py_ssize_t di, dj, k, n = 0
    for di in range(3):
        for dj in range(3):
            v[3 * di + dj] = p[i + di, j + dj]
    if not isnan(v[0] + v[1] + v[2] + v[3] + v[4] + v[5] + v[6] + v[7] + v[8]):
        _order(&v[1], &v[2]); _order(&v[4], &v[5]); _order(&v[7], &v[8])
        _order(&v[0], &v[1]); _order(&v[3], &v[4]); _order(&v[6], &v[7])
        _order(&v[1], &v[2]); _order(&v[4], &v[5]); _order(&v[7], &v[8])
        _order(&v[0], &v[3]); _order(&v[5], &v[8]); _order(&v[4], &v[7])
        _order(&v[3], &v[6]); _order(&v[1], &v[4]); _order(&v[2], &v[5])
        _order(&v[4], &v[7]); _order(&v[4], &v[2]); _order(&v[6], &v[4])
        _order(&v[4], &v[2])
        return v[4]
    for k in range(9):
        x = v[k]
        if not isnan(x):
            di = n
            while di > 0 and buf[di - 1] > x:
                buf[di] = buf[di - 1]
                di -= 1
            buf[di] = x
            n += 1
    if n == 0:
        return NAN
    return buf[n // 2] if n % 2 else 0.5 * (buf[n // 2 - 1] + buf[n // 2])


def window_median(const double[:, ::1] p, Py_ssize_t i, Py_ssize_t j):
    """NaN-aware median of the 3 x 3 window ``p[i:i+3, j:j+3]`` (np.nanmedian's value)."""
    cdef double[::1] buf = np.empty(9)
    return _window_median(p, i, j, buf)


cdef double[:, ::1] _despike(const double[:, ::1] grid):
    """Tiles that stand out from their 3 x 3 neighbourhood (or are NaN) replaced by its
    median. Only outliers: a median filter over the whole grid would also erase the
    tile-to-tile corrections that the second background pass exists to make."""
    cdef Py_ssize_t n_r = grid.shape[0], n_c = grid.shape[1], i, j
    cdef const double[:, ::1] p = _pad_odd(grid)
    cdef double[:, ::1] local = np.empty((n_r, n_c)), deviation = np.empty((n_r, n_c))
    cdef double[::1] buf = np.empty(9)
    cdef bint all_nan = True
    for i in range(n_r):
        for j in range(n_c):
            local[i, j] = _window_median(p, i, j, buf)
            deviation[i, j] = fabs(grid[i, j] - local[i, j])
            all_nan &= isnan(deviation[i, j])
    if all_nan:
        return local
    cdef double spread = MAD_TO_SIGMA * _nanmedian(deviation)
    cdef double[:, ::1] out = np.array(grid)
    for i in range(n_r):
        for j in range(n_c):
            if isnan(grid[i, j]) or deviation[i, j] > 3.0 * spread:
                out[i, j] = local[i, j]
    return out


cdef bint _any_nan(const double[:, ::1] grid):
    cdef Py_ssize_t i, j
    for i in range(grid.shape[0]):
        for j in range(grid.shape[1]):
            if isnan(grid[i, j]):
                return True
    return False


def clean_grid(const double[:, ::1] raw, bint average, double fallback):
    """Tiles spoiled by a bright star replaced from their neighbours; with ``average`` the
    grid is then smoothed by a 3 x 3 mean (planes pass unchanged). NaN tiles left over
    take the grid's median (``fallback`` when every tile is NaN). A new array."""
    cdef Py_ssize_t n_r = raw.shape[0], n_c = raw.shape[1], i, j, di, dj
    cdef double[:, ::1] grid, p
    cdef double s, value
    if n_r >= 3 and n_c >= 3:
        grid = _despike(raw)
        if average and not _any_nan(grid):
            p = _pad_odd(grid)
            for i in range(n_r):
                for j in range(n_c):
                    s = 0.0  # numpy's sum of the window: in order, from 0
                    for di in range(3):
                        for dj in range(3):
                            s += p[i + di, j + dj]
                    grid[i, j] = s / 9.0
    else:
        grid = np.array(raw)
    if _any_nan(grid):
        value = _nanmedian(grid)
        if isnan(value):
            value = fallback
        for i in range(n_r):
            for j in range(n_c):
                if isnan(grid[i, j]):
                    grid[i, j] = value
    return np.asarray(grid)


def median(const double[::1] values):
    """np.median of ``values`` (no NaN)."""
    cdef double[::1] scratch = np.empty(values.shape[0])
    cdef long long[::1] counts = np.empty(256, np.int64)
    cdef double out
    with nogil:
        out = median_copy(values, scratch, counts)
    return out


def middle(double[::1] values, Py_ssize_t n, long long[::1] counts):
    """np.median of ``values[:n]`` (no NaN), which it reorders; ``counts``: histogram
    scratch."""
    cdef double out
    with nogil:
        out = _middle(values, n, counts)
    return out


def mad_sigma(const double[::1] sample, double to_sigma):
    """``to_sigma`` x the median absolute deviation of ``sample`` (not modified)."""
    cdef double[::1] scratch = np.empty(sample.shape[0])
    cdef long long[::1] counts = np.empty(4096, np.int64)
    cdef double out
    with nogil:
        out = to_sigma * _mad(sample, scratch, counts)
    return out
