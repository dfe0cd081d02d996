"""Compiled pixel kernels of the centroider: residual rows, noise samples, run-length blobs.

Every kernel reads the raw frame (any numeric dtype) and evaluates the sky model on the
fly, so no full-size float copy of the frame, background or residual is ever made (the
sky model itself comes from ``extract_blocks``'s block means). The sky model is a tuple
``(grid, r0, r1, fr, c0, c1, fc, rows)``: tile values and, per row and per column, the two
tiles to interpolate between and the weight of the second (bilinear, linear extrapolation
at the border), and the tile rows interpolated along the columns (``column_rows``). A
residual is the pixel minus the model; a non-finite pixel's residual is 0.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

# Columns of the per-run accumulator and of the components that ``components`` returns.
SW, SWX, SWY, FLUX, AREA, SAT, PEAK, PEAK_AT = range(8)
_N_ACC = 8
_CHUNK = 32  # px, the unit in which rows are searched for detections


@njit(cache=True)
def column_rows(grid, c0, c1, fc):
    """Each tile row of the sky model interpolated along the columns (tile rows x W).

    A model row is then the blend of two of these: a residual row needs no gather.
    """
    out = np.empty((grid.shape[0], c0.shape[0]))
    for i in range(grid.shape[0]):
        for c in range(c0.shape[0]):
            out[i, c] = grid[i, c0[c]] * (1.0 - fc[c]) + grid[i, c1[c]] * fc[c]
    return out


@njit(cache=True)
def background_row(model, r, out):
    """The sky model along row ``r``."""
    g, a, b, t = model[7], model[1][r], model[2][r], model[3][r]
    for c in range(out.shape[0]):
        out[c] = g[a, c] * (1.0 - t) + g[b, c] * t


@njit(cache=True)
def residual_row(image, model, r, out):
    """Row ``r`` of the frame minus the sky model into ``out``."""
    g, a, b, t = model[7], model[1][r], model[2][r], model[3][r]
    for c in range(out.shape[0]):
        v = float(image[r, c])
        bg = g[a, c] * (1.0 - t) + g[b, c] * t
        out[c] = v - bg if math.isfinite(v) else 0.0


@njit(cache=True)
def _smooth_row(above, mid, below, vbuf, out):
    """3 x 3 Gaussian ([1, 2, 1] / 4 each way, reflect-101 borders, as cv2.GaussianBlur)."""
    w = mid.shape[0]
    for c in range(w):
        vbuf[c] = 0.25 * above[c] + 0.5 * mid[c] + 0.25 * below[c]
    if w == 1:
        out[0] = vbuf[0]
        return
    for c in range(1, w - 1):  # no border test inside: the loop vectorises
        out[c] = 0.25 * vbuf[c - 1] + 0.5 * vbuf[c] + 0.25 * vbuf[c + 1]
    out[0] = 0.5 * vbuf[0] + 0.5 * vbuf[1]
    out[w - 1] = 0.5 * vbuf[w - 1] + 0.5 * vbuf[w - 2]


@njit(cache=True)
def _reflect101(i, n):
    if n == 1:
        return 0
    if i < 0:
        return -i
    if i >= n:
        return 2 * n - 2 - i
    return i


@njit(cache=True)
def _detection_row(image, model, r, ring, vbuf, out, smooth):
    """The detection image's row ``r`` (smoothed residual, or the residual itself).

    ``ring`` (3 x W) holds residual rows r - 1, r and r + 1 at index row % 3, and is
    advanced here by one row: call for r = 0, 1, 2, ... in order.
    """
    h = image.shape[0]
    if r == 0:
        residual_row(image, model, 0, ring[0])
        if h > 1:
            residual_row(image, model, 1, ring[1])
    elif r + 1 < h:
        residual_row(image, model, r + 1, ring[(r + 1) % 3])
    mid = ring[r % 3]
    if not smooth:
        out[:] = mid
        return mid
    above = ring[_reflect101(r - 1, h) % 3]
    below = ring[_reflect101(r + 1, h) % 3]
    _smooth_row(above, mid, below, vbuf, out)
    return mid


@njit(cache=True)
def samples(image, model, step, smooth):
    """Residual and detection-image values on the grid [::step, ::step], for noise stats."""
    h, w = image.shape
    rows = np.empty((3, w))
    cols = np.arange(0, w, step)
    n_rows = (h + step - 1) // step
    res = np.empty(n_rows * len(cols))
    det = np.empty(n_rows * len(cols))
    k = 0
    for r in range(0, h, step):
        for d in range(3):
            residual_row(image, model, _reflect101(r + d - 1, h), rows[d])
        for c in cols:
            res[k] = rows[1, c]
            if smooth:
                left, right = _reflect101(c - 1, w), _reflect101(c + 1, w)
                v_l = 0.25 * rows[0, left] + 0.5 * rows[1, left] + 0.25 * rows[2, left]
                v_c = 0.25 * rows[0, c] + 0.5 * rows[1, c] + 0.25 * rows[2, c]
                v_r = 0.25 * rows[0, right] + 0.5 * rows[1, right] + 0.25 * rows[2, right]
                det[k] = 0.25 * v_l + 0.5 * v_c + 0.25 * v_r
            else:
                det[k] = rows[1, c]
            k += 1
    return res, det


@njit(cache=True)
def _find(parent, i):
    root = i
    while parent[root] != root:
        root = parent[root]
    while parent[i] != root:  # path compression
        parent[i], i = root, parent[i]
    return root


@njit(cache=True)
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


@njit(cache=True)
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


@njit(cache=True)
def _row_runs(det, threshold, out):
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


@njit(cache=True)
def components(image, model, threshold, smooth, sat_level):
    """8-connected components of detection > ``threshold``, streamed row by row.

    Runs of detected pixels in each row are joined to the runs they touch in the row
    above (union-find), and their residual moments summed, so no label image is made.
    Returns one row per component: columns SW .. PEAK_AT (PEAK_AT a raster index).
    """
    h, w = image.shape
    ring = np.empty((3, w))
    vbuf, det = np.empty(w), np.empty(w)
    acc = np.empty((1024, _N_ACC))
    parent = np.empty(1024, np.int64)
    runs = np.empty((2, 3, w // 2 + 1), np.int64)  # (previous, current) x (start, end, id)
    n_runs = n_prev = 0
    for r in range(h):
        res = _detection_row(image, model, r, ring, vbuf, det, smooth)
        prev, cur = runs[(r + 1) % 2], runs[r % 2]
        n_cur = _row_runs(det, threshold, cur)
        if n_runs + n_cur > len(parent):
            grow = max(len(parent), n_cur)
            acc = np.concatenate((acc, np.empty((grow, _N_ACC))))
            parent = np.concatenate((parent, np.empty(grow, np.int64)))
        k = 0
        for i in range(n_cur):
            s, e, rid = cur[0, i], cur[1, i], n_runs + i
            parent[rid] = rid
            cur[2, i] = rid
            _add_run(acc, rid, image, res, r, s, e, sat_level)
            while k < n_prev and prev[1, k] < s - 1:
                k += 1
            m = k
            while m < n_prev and prev[0, m] <= e + 1:  # touches, diagonals included
                a, b = _find(parent, prev[2, m]), _find(parent, rid)
                parent[max(a, b)] = min(a, b)
                m += 1
        n_runs += n_cur
        n_prev = n_cur
    return _merge(acc, parent, n_runs)


@njit(cache=True)
def peak_boxes(image, model, peak_at):
    """Residual summed over the 3 x 3 box around each peak (reflected at the border)."""
    h, w = image.shape
    g, r0, r1, fr = model[7], model[1], model[2], model[3]
    out = np.zeros(len(peak_at))
    for i in range(len(peak_at)):
        pr, pc = divmod(int(peak_at[i]), w)
        for dr in range(-1, 2):
            r = min(max(pr + dr, 0), h - 1)  # one pixel past the border reflects onto it
            a, b, t = r0[r], r1[r], fr[r]
            for dc in range(-1, 2):
                c = min(max(pc + dc, 0), w - 1)
                v = float(image[r, c])
                if math.isfinite(v):
                    out[i] += v - (g[a, c] * (1.0 - t) + g[b, c] * t)
    return out


@njit(cache=True)
def background_image(model, h, w):
    """The sky model as a float32 image (for inspection and tests)."""
    out = np.empty((h, w), np.float32)
    row = np.empty(w)
    for r in range(h):
        background_row(model, r, row)
        out[r] = row
    return out
