"""Compiled blob finder of the centroider: run-length 8-connected components and moments.

``band_runs`` walks a band of rows (detection rows made on the fly by ``extract_kernels``)
and returns its runs of detected pixels with their residual moments; bands are
independent, so they run on threads at once. ``join_runs`` then joins the runs of all
bands, in raster order, into components (union-find) and sums their moments in that
order: the same sums, in the same order, however the frame was cut into bands.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from startrack.extract_kernels import detection_row

# Columns of the per-run accumulator and of the components that ``join_runs`` returns.
SW, SWX, SWY, FLUX, AREA, SAT, PEAK, PEAK_AT = range(8)
_N_ACC = 8
_CHUNK = 32  # px, the unit in which rows are searched for detections


@njit(cache=True, nogil=True)
def _find(parent, i):
    root = i
    while parent[root] != root:
        root = parent[root]
    while parent[i] != root:  # path compression
        parent[i], i = root, parent[i]
    return root


@njit(cache=True, nogil=True)
def _add_run(acc, rid, image, res_row, r, s, e, sat_level):
    """Moments of one run (row r, columns s..e) of detected pixels into ``acc[rid]``."""
    w = image.shape[1]
    sw = swx = flux = 0.0
    sat = 0.0
    peak, at = -np.inf, 0.0
    for c in range(s, e + 1):
        v = res_row[c]
        wgt = max(v, 0.0)  # negative noise pixels would pull the centroid off the star
        sw += wgt
        swx += wgt * c
        flux += v
        if float(image[r, c]) >= sat_level:
            sat = 1.0
        if v >= peak:  # ties: the last pixel in raster order
            peak, at = v, float(r * w + c)
    acc[rid, SW], acc[rid, SWX], acc[rid, SWY] = sw, swx, sw * r
    acc[rid, FLUX], acc[rid, AREA], acc[rid, SAT] = flux, e - s + 1.0, sat
    acc[rid, PEAK], acc[rid, PEAK_AT] = peak, at


@njit(cache=True, nogil=True)
def _merge(acc, parent, n_runs):
    """Sum the runs of each 8-connected component: one row of ``acc`` columns each."""
    for i in range(n_runs):
        root = _find(parent, i)
        if root == i:
            continue
        for k in (SW, SWX, SWY, FLUX, AREA):
            acc[root, k] += acc[i, k]
        acc[root, SAT] = max(acc[root, SAT], acc[i, SAT])
        if acc[i, PEAK] > acc[root, PEAK] or (acc[i, PEAK] == acc[root, PEAK]
                                              and acc[i, PEAK_AT] > acc[root, PEAK_AT]):
            acc[root, PEAK], acc[root, PEAK_AT] = acc[i, PEAK], acc[i, PEAK_AT]
    n = 0
    for i in range(n_runs):
        if parent[i] == i:
            acc[n] = acc[i]
            n += 1
    return acc[:n].copy()


@njit(cache=True, nogil=True)
def row_runs(det, threshold, out):
    """Runs of ``det > threshold`` as (start, end) pairs in ``out``; returns their count.

    Most of a row lies below the threshold: it is tested in chunks by a vectorised count,
    and only chunks with a pixel above are walked pixel by pixel.
    """
    w = det.shape[0]
    n, inside = 0, False
    for c0 in range(0, w, _CHUNK):
        c1 = min(c0 + _CHUNK, w)
        above = 0
        for c in range(c0, c1):
            above += det[c] > threshold
        if above == 0:
            if inside:
                out[1, n] = c0 - 1
                n += 1
                inside = False
            continue
        for c in range(c0, c1):
            if det[c] > threshold:
                if not inside:
                    out[0, n] = c
                    inside = True
            elif inside:
                out[1, n] = c - 1
                n += 1
                inside = False
    if inside:
        out[1, n] = w - 1
        n += 1
    return n


@njit(cache=True, nogil=True)
def band_runs(image, model, threshold, smooth, sat_level, r_start, r_stop):
    """Runs of detection > ``threshold`` in rows ``r_start`` .. ``r_stop - 1``, in raster
    order: (row, first column, last column) each, and their moments (columns SW ..
    PEAK_AT of ``acc``, PEAK_AT a raster index)."""
    w = image.shape[1]
    ring = np.empty((3, w))
    vbuf, det = np.empty(w), np.empty(w)
    spans = np.empty((2, w // 2 + 1), np.int64)
    runs = np.empty((256, 3), np.int64)
    acc = np.empty((256, _N_ACC))
    n = 0
    for r in range(r_start, r_stop):
        res = detection_row(image, model, r, r_start, ring, vbuf, det, smooth)
        n_cur = row_runs(det, threshold, spans)
        if n + n_cur > len(runs):
            grow = max(len(runs), n_cur)
            runs = np.concatenate((runs, np.empty((grow, 3), np.int64)))
            acc = np.concatenate((acc, np.empty((grow, _N_ACC))))
        for i in range(n_cur):
            runs[n, 0], runs[n, 1], runs[n, 2] = r, spans[0, i], spans[1, i]
            _add_run(acc, n, image, res, r, spans[0, i], spans[1, i], sat_level)
            n += 1
    return runs[:n].copy(), acc[:n].copy()


@njit(cache=True, nogil=True)
def join_runs(runs, acc):
    """The 8-connected components of ``runs`` (raster order, as ``band_runs`` gives
    them), one row of summed moments each (``acc`` is overwritten)."""
    n_runs = len(runs)
    parent = np.arange(n_runs)
    prev_lo = prev_hi = row_lo = k = 0  # runs[prev_lo:prev_hi]: those of the row above
    for i in range(n_runs):
        r, s, e = runs[i, 0], runs[i, 1], runs[i, 2]
        if i > 0 and r != runs[i - 1, 0]:  # a new row
            prev_lo, prev_hi = (row_lo, i) if runs[i - 1, 0] == r - 1 else (i, i)
            row_lo, k = i, prev_lo
        while k < prev_hi and runs[k, 2] < s - 1:
            k += 1
        m = k
        while m < prev_hi and runs[m, 1] <= e + 1:  # touches, diagonals included
            a, b = _find(parent, m), _find(parent, i)
            parent[max(a, b)] = min(a, b)
            m += 1
    return _merge(acc, parent, n_runs)


@njit(cache=True, nogil=True)
def stars(comp, box, hot_fraction, hot_margin, min_area, max_area, max_saturated):
    """The components of ``comp`` that are stars, as (x, y, flux, saturated, area) arrays
    in their order: area within [min_area, max_area] (``max_saturated`` with a saturated
    pixel), positive weight and flux, and not a hot pixel: the peak holds no more than
    ``hot_fraction`` of the 3 x 3 ``box`` around it, whose other pixels hold at least
    ``hot_margin``."""
    keep = np.zeros(len(comp), np.bool_)
    for i in range(len(comp)):
        peak, area, sat = comp[i, PEAK], np.int64(comp[i, AREA]), comp[i, SAT] > 0
        hot = (peak > hot_fraction * box[i]) | (box[i] - peak < hot_margin)
        keep[i] = (area >= min_area) & (area <= (max_saturated if sat else max_area)) \
            & (not hot) & (comp[i, SW] > 0) & (comp[i, FLUX] > 0)
    at = np.nonzero(keep)[0]
    sw = comp[at, SW]
    return (comp[at, SWX] / sw, comp[at, SWY] / sw, comp[at, FLUX], comp[at, SAT] > 0,
            comp[at, AREA].astype(np.int64))
