"""Compiled pixel kernels of the centroider: residual and detection rows, noise samples.

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


@njit(cache=True, nogil=True)
def column_rows(grid, c0, c1, fc):
    """Each tile row of the sky model interpolated along the columns (tile rows x W).

    A model row is then the blend of two of these: a residual row needs no gather.
    """
    out = np.empty((grid.shape[0], c0.shape[0]))
    for i in range(grid.shape[0]):
        for c in range(c0.shape[0]):
            out[i, c] = grid[i, c0[c]] * (1.0 - fc[c]) + grid[i, c1[c]] * fc[c]
    return out


@njit(cache=True, nogil=True)
def background_row(model, r, out):
    """The sky model along row ``r``."""
    g, a, b, t = model[7], model[1][r], model[2][r], model[3][r]
    for c in range(out.shape[0]):
        out[c] = g[a, c] * (1.0 - t) + g[b, c] * t


@njit(cache=True, nogil=True)
def residual_row(image, model, r, out):
    """Row ``r`` of the frame minus the sky model into ``out``."""
    g, a, b, t = model[7], model[1][r], model[2][r], model[3][r]
    for c in range(out.shape[0]):
        v = float(image[r, c])
        bg = g[a, c] * (1.0 - t) + g[b, c] * t
        out[c] = v - bg if math.isfinite(v) else 0.0


@njit(cache=True, nogil=True)
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


@njit(cache=True, nogil=True)
def _reflect101(i, n):
    if n == 1:
        return 0
    if i < 0:
        return -i
    if i >= n:
        return 2 * n - 2 - i
    return i


@njit(cache=True, nogil=True)
def detection_row(image, model, r, first, ring, vbuf, out, smooth):
    """The detection image's row ``r`` (smoothed residual, or the residual itself) into
    ``out``; returns the residual row ``r``.

    ``ring`` (3 x W) holds residual rows r - 1, r and r + 1 at index row % 3, and is
    advanced here by one row: call for r = first, first + 1, ... in order.
    """
    h = image.shape[0]
    if r == first:
        residual_row(image, model, r, ring[r % 3])
        if r > 0:
            residual_row(image, model, r - 1, ring[(r - 1) % 3])
    if r + 1 < h:
        residual_row(image, model, r + 1, ring[(r + 1) % 3])
    mid = ring[r % 3]
    if not smooth:
        out[:] = mid
        return mid
    above = ring[_reflect101(r - 1, h) % 3]
    below = ring[_reflect101(r + 1, h) % 3]
    _smooth_row(above, mid, below, vbuf, out)
    return mid


@njit(cache=True, nogil=True)
def samples(image, model, step, smooth, k_start, k_stop, res, det):
    """Residual and detection-image values on the grid [::step, ::step], for noise stats:
    sampled rows ``k_start`` .. ``k_stop - 1`` (row k is image row k * step) into their
    places in ``res`` and ``det`` (len(range(0, W, step)) values a row)."""
    h, w = image.shape
    rows = np.empty((3, w))
    cols = np.arange(0, w, step)
    i = k_start * len(cols)
    for k in range(k_start, k_stop):
        r = k * step
        for d in range(3):
            residual_row(image, model, _reflect101(r + d - 1, h), rows[d])
        for c in cols:
            res[i] = rows[1, c]
            if smooth:
                left, right = _reflect101(c - 1, w), _reflect101(c + 1, w)
                v_l = 0.25 * rows[0, left] + 0.5 * rows[1, left] + 0.25 * rows[2, left]
                v_c = 0.25 * rows[0, c] + 0.5 * rows[1, c] + 0.25 * rows[2, c]
                v_r = 0.25 * rows[0, right] + 0.5 * rows[1, right] + 0.25 * rows[2, right]
                det[i] = 0.25 * v_l + 0.5 * v_c + 0.25 * v_r
            else:
                det[i] = rows[1, c]
            i += 1


@njit(cache=True, nogil=True)
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


@njit(cache=True, nogil=True)
def background_image(model, h, w):
    """The sky model as a float32 image (for inspection and tests)."""
    out = np.empty((h, w), np.float32)
    row = np.empty(w)
    for r in range(h):
        background_row(model, r, row)
        out[r] = row
    return out
