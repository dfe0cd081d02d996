"""Compiled iterations of the camera fit (:func:`startrack.solver._fov_fit.fit_camera`): the pixels
turned into directions through the current focal length and lens, Wahba's attitude, then
the linear least squares of the focal length (and a fitted k1), until they settle.

The fit runs for every solved frame whose field of view was given as nominal, and for
every hypothesis of a blind search; in numpy a few dozen stars spent half a millisecond an
iteration in call overhead. Each step here is the numpy fit's (kept as the tests' reference,
``tests/fov_fit_reference.py``), operation for operation, except Wahba's problem
(Davenport's q-method instead of an SVD, the same minimiser) and the two-column least
squares (a Gram-Schmidt QR instead of LAPACK's SVD solver).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from startrack.matching.wahba_kernels import wahba

#: What :func:`fit_iterations` ended on (its first return value).
SETTLED, BAD_FOCAL, FOLDS = 0, 1, 2
#: Newton steps of the lens inversion at most (startrack.camera._distortion.NEWTON_ITERATIONS)
NEWTON_ITERATIONS = 12


@njit(cache=True)
def _factor(r2, k1, k2, k3):
    return 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))


@njit(cache=True)
def _undistort(u, v, k1, k2, k3, r_cap):
    """:meth:`startrack.camera._distortion.RadialDistortion.undistort` in place: Newton on the
    radius, every star stepped until no step exceeds 1e-15, clipped to [0, r_cap]."""
    n = u.shape[0]
    rd = np.empty(n)
    r = np.empty(n)
    for i in range(n):
        rd[i] = math.hypot(u[i], v[i])
        r[i] = min(rd[i], r_cap)
    for _ in range(NEWTON_ITERATIONS):
        moving = False
        for i in range(n):
            r2 = r[i] * r[i]
            slope = 1.0 + r2 * (3.0 * k1 + r2 * (5.0 * k2 + r2 * 7.0 * k3))
            step = (r[i] * _factor(r2, k1, k2, k3) - rd[i]) / slope
            moving |= abs(step) > 1e-15
            r[i] = min(max(r[i] - step, 0.0), r_cap)
        if not moving:
            break
    for i in range(n):
        scale = r[i] / rd[i] if rd[i] > 0.0 else 1.0
        u[i] *= scale
        v[i] *= scale


@njit(cache=True)
def k1_fold_r2(k1):
    """:attr:`startrack.camera._distortion.RadialDistortion.max_r2` of a k1-only lens."""
    return -1.0 / (3.0 * k1) if k1 < 0.0 else np.inf


@njit(cache=True)
def _folds(width, height, cx, cy, f, k1):
    """Whether a k1-only lens folds back inside the image
    (:meth:`startrack.camera._model.Camera.with_distortion`'s refusal)."""
    ex = max(abs(-0.5 - cx), abs(width - 0.5 - cx))
    ey = max(abs(-0.5 - cy), abs(height - 0.5 - cy))
    rd2 = (ex * ex + ey * ey) / (f * f)
    r2 = k1_fold_r2(k1)
    return math.isfinite(r2) and rd2 >= r2 * _factor(r2, k1, 0.0, 0.0) ** 2


@njit(cache=True)
def _two_column_lsq(a1, a2, d):
    """The least-squares (x1, x2) of a1 x1 + a2 x2 = d (the minimum-norm one when the
    columns are parallel), by Gram-Schmidt."""
    r11 = math.sqrt(np.dot(a1, a1))
    if r11 == 0.0:
        return 0.0, 0.0
    q1 = a1 / r11
    r12 = np.dot(q1, a2)
    w = a2 - r12 * q1
    r22 = math.sqrt(np.dot(w, w))
    b1 = np.dot(q1, d)
    if r22 <= 1e-12 * r11:  # a2 = c a1: x = (1, c) b1 / (r11 (1 + c^2))
        c = r12 / r11
        x1 = b1 / (r11 * (1.0 + c * c))
        return x1, c * x1
    x2 = np.dot(w / r22, d) / r22
    return (b1 - r12 * x2) / r11, x2


@njit(cache=True)
def fit_iterations(x, y, cat, cx, cy, width, height, f, lens, lens_cap, with_k1,
                   iterations, min_r2, max_k1):
    """Alternate Wahba's attitude and the focal length's (and k1's) least squares from
    focal length ``f``. ``lens``: a described lens's (k1, k2, k3) (zeros: none) and
    ``lens_cap`` its fold radius; ``with_k1``: fit a k1 of an undescribed lens when the
    stars reach ``min_r2``, within +-``max_k1``. Returns (SETTLED, BAD_FOCAL: a focal length
    not positive and finite, or FOLDS: a fitted k1 that folds back inside the image; the
    focal length; the fitted k1)."""
    m = x.shape[0]
    dx, dy = x - cx, y - cy
    described = lens[0] != 0.0 or lens[1] != 0.0 or lens[2] != 0.0
    k1 = 0.0
    u, v = np.empty(m), np.empty(m)
    cam = np.empty((m, 3))
    for _ in range(iterations):
        for i in range(m):
            u[i], v[i] = dx[i] / f, dy[i] / f
        if described:
            _undistort(u, v, lens[0], lens[1], lens[2], lens_cap)
        elif k1 != 0.0:
            _undistort(u, v, k1, 0.0, 0.0, math.sqrt(k1_fold_r2(k1)))
        for i in range(m):
            norm = math.sqrt(u[i] * u[i] + v[i] * v[i] + 1.0)
            cam[i, 0], cam[i, 1], cam[i, 2] = u[i] / norm, v[i] / norm, 1.0 / norm
        rot = wahba(cam, cat)
        tx, ty, r2 = np.empty(m), np.empty(m), np.empty(m)
        for i in range(m):  # the catalog direction in the camera frame: R^T v
            c0 = cat[i, 0] * rot[0, 0] + cat[i, 1] * rot[1, 0] + cat[i, 2] * rot[2, 0]
            c1 = cat[i, 0] * rot[0, 1] + cat[i, 1] * rot[1, 1] + cat[i, 2] * rot[2, 1]
            c2 = cat[i, 0] * rot[0, 2] + cat[i, 1] * rot[1, 2] + cat[i, 2] * rot[2, 2]
            tx[i], ty[i] = c0 / c2, c1 / c2
            if described:  # the lens acts on the normalised plane
                s = _factor(tx[i] * tx[i] + ty[i] * ty[i], lens[0], lens[1], lens[2])
                tx[i], ty[i] = tx[i] * s, ty[i] * s
            r2[i] = tx[i] * tx[i] + ty[i] * ty[i]
        if with_k1 and r2.max() >= min_r2:
            a1 = np.empty(2 * m)
            a2 = np.empty(2 * m)
            d = np.empty(2 * m)
            for i in range(m):  # rows interleaved x, y per star, as t.ravel()
                a1[2 * i], a1[2 * i + 1] = tx[i], ty[i]
                a2[2 * i], a2[2 * i + 1] = tx[i] * r2[i], ty[i] * r2[i]
                d[2 * i], d[2 * i + 1] = dx[i], dy[i]
            f_new, g = _two_column_lsq(a1, a2, d)
            k1_new = min(max(g / f_new, -max_k1), max_k1) if f_new > 0.0 else 0.0
        elif r2.sum() > 0.0:
            f_new = (np.dot(dx, tx) + np.dot(dy, ty)) / r2.sum()
            k1_new = 0.0
        else:
            break
        done = abs(f_new - f) <= 1e-10 * abs(f) and abs(k1_new - k1) <= 1e-12
        f, k1 = f_new, k1_new
        if not (f > 0.0 and math.isfinite(f)):
            return BAD_FOCAL, f, k1
        if k1 != 0.0 and _folds(width, height, cx, cy, f, k1):
            return FOLDS, f, k1
        if done:
            break
    return SETTLED, f, k1

