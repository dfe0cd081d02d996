"""The centroider's blobs: runs of detected pixels joined into 8-connected components,
and the components that are stars, with their intensity-weighted centroids.

``join_runs`` takes the runs of every band of rows (``extract.band_runs``) in raster
order and sums each component's moments in that order, so the sums do not depend on how
the frame was cut into bands.
"""

import numpy as np

from libc.math cimport sqrt

#: the elongation of a one-pixel-wide line (no width to measure) and of anything longer
MAX_ELONGATION = 100.0

# Columns of the moments (as in ``extract``): weight, weighted column and row, their
# weighted squares and product, flux, area, saturated, peak residual, the peak's raster
# index.
cdef enum:
    SW, SWX, SWY, SWXX, SWXY, SWYY, FLUX, AREA, SAT, PEAK, PEAK_AT, N_ACC


cdef Py_ssize_t _find(Py_ssize_t[::1] parent, Py_ssize_t i) noexcept nogil:
    cdef Py_ssize_t root = i, nxt
    while parent[root] != root:
        root = parent[root]
    while parent[i] != root:  # path compression
        nxt = parent[i]
        parent[i] = root
        i = nxt
    return root


cdef Py_ssize_t _merge(double[:, ::1] acc, Py_ssize_t[::1] parent) noexcept nogil:
    """Sum the runs of each component into its first run's row, then pack those rows to
    the top of ``acc``; returns their count."""
    cdef Py_ssize_t n_runs = parent.shape[0], i, root, n = 0, k
    for i in range(n_runs):
        root = _find(parent, i)
        if root == i:
            continue
        for k in range(AREA + 1):  # the moments, FLUX and AREA
            acc[root, k] += acc[i, k]
        acc[root, SAT] = max(acc[root, SAT], acc[i, SAT])
        if acc[i, PEAK] > acc[root, PEAK] or (acc[i, PEAK] == acc[root, PEAK]
                                              and acc[i, PEAK_AT] > acc[root, PEAK_AT]):
            acc[root, PEAK], acc[root, PEAK_AT] = acc[i, PEAK], acc[i, PEAK_AT]
    for i in range(n_runs):
        if parent[i] == i:
            for k in range(N_ACC):
                acc[n, k] = acc[i, k]
            n += 1
    return n


cdef void _join(const long long[:, ::1] runs, Py_ssize_t[::1] parent) noexcept nogil:
    """Union of every run with the runs of the row above that it touches (diagonals
    included)."""
    cdef Py_ssize_t n_runs = runs.shape[0], i, m, k = 0, a, b
    cdef Py_ssize_t prev_lo = 0, prev_hi = 0, row_lo = 0  # runs[prev_lo:prev_hi]: the row above
    cdef long long r, s, e
    for i in range(n_runs):
        r, s, e = runs[i, 0], runs[i, 1], runs[i, 2]
        if i > 0 and r != runs[i - 1, 0]:  # a new row
            if runs[i - 1, 0] == r - 1:
                prev_lo, prev_hi = row_lo, i
            else:
                prev_lo, prev_hi = i, i
            row_lo, k = i, prev_lo
        while k < prev_hi and runs[k, 2] < s - 1:
            k += 1
        m = k
        while m < prev_hi and runs[m, 1] <= e + 1:
            a, b = _find(parent, m), _find(parent, i)
            parent[max(a, b)] = min(a, b)
            m += 1


def join_runs(const long long[:, ::1] runs, double[:, ::1] acc):
    """The 8-connected components of ``runs`` (raster order, as ``band_runs`` gives
    them), one row of summed moments each (``acc`` is overwritten)."""
    cdef Py_ssize_t[::1] parent = np.arange(runs.shape[0], dtype=np.intp)
    cdef Py_ssize_t n
    with nogil:
        _join(runs, parent)
        n = _merge(acc, parent)
    return np.array(np.asarray(acc)[:n])


def stars(const double[:, ::1] comp, const double[::1] box, double hot_fraction,
          double hot_margin, long long min_area, long long max_area, long long max_saturated):
    """The components of ``comp`` that are stars, as a dict of arrays (``x``, ``y``,
    ``flux``, ``saturated``, ``area``, ``elongation``; the fields of ``Centroids``) in
    their order: area within [min_area, max_area] (``max_saturated`` with a saturated
    pixel), positive weight and flux, and not a hot pixel: the peak holds no more than
    ``hot_fraction`` of the 3 x 3 ``box`` around it, whose other pixels hold at least
    ``hot_margin``. ``elongation``: the ratio of the weighted image's principal axes (the
    square root of its second moments' eigenvalues), at most MAX_ELONGATION."""
    cdef Py_ssize_t i, n = 0
    cdef long long area
    cdef bint sat, hot
    cdef double mx, my, vxx, vyy, vxy, half, disc, lo
    elongation = np.empty(comp.shape[0])
    cdef double[::1] eo = elongation
    x, y = np.empty(comp.shape[0]), np.empty(comp.shape[0])
    flux, saturated = np.empty(comp.shape[0]), np.empty(comp.shape[0], np.bool_)
    areas = np.empty(comp.shape[0], np.int64)
    cdef double[::1] xo = x, yo = y, fo = flux
    cdef long long[::1] ao = areas
    cdef unsigned char[::1] so = saturated.view(np.uint8)
    for i in range(comp.shape[0]):
        area, sat = <long long>comp[i, AREA], comp[i, SAT] > 0
        hot = (comp[i, PEAK] > hot_fraction * box[i]) or (box[i] - comp[i, PEAK] < hot_margin)
        if (min_area <= area <= (max_saturated if sat else max_area) and not hot
                and comp[i, SW] > 0 and comp[i, FLUX] > 0):
            xo[n], yo[n] = comp[i, SWX] / comp[i, SW], comp[i, SWY] / comp[i, SW]
            fo[n], so[n], ao[n] = comp[i, FLUX], sat, area
            mx, my = xo[n], yo[n]
            vxx = comp[i, SWXX] / comp[i, SW] - mx * mx
            vyy = comp[i, SWYY] / comp[i, SW] - my * my
            vxy = comp[i, SWXY] / comp[i, SW] - mx * my
            half = 0.5 * (vxx + vyy)
            disc = sqrt(max(0.0, half * half - (vxx * vyy - vxy * vxy)))
            lo = half - disc
            eo[n] = (MAX_ELONGATION if lo * MAX_ELONGATION ** 2 <= half + disc
                     else sqrt((half + disc) / lo))
            n += 1
    return {"x": x[:n].copy(), "y": y[:n].copy(), "flux": flux[:n].copy(),
            "saturated": saturated[:n].copy(), "area": areas[:n].copy(),
            "elongation": elongation[:n].copy()}
