"""The camera refit's fit in numpy, as startrack.verify._refit computed it before the fit
moved into the compiled core (startrack/_core/verify/camera_refit.pyx). Kept as the
reference tests/verify/test_camera_refit_kernel.py holds the kernel to: the same pairs, and
parameters equal to rounding."""

from __future__ import annotations

import numpy as np

from startrack.verify._refit import DAMPING, ITERATIONS, K1_CHI2, MIN_PAIRS, ROUNDS

#: finite-difference steps: rotation (rad), focal length (fraction of it), centre (px), k1
_STEPS = np.array([1e-6, 1e-6, 1e-6, 1e-6, 1e-3, 1e-3, 1e-6])


def _rotation(w: np.ndarray) -> np.ndarray:
    """Rotation matrices (K x 3 x 3) of rotation vectors ``w`` (K x 3), by Rodrigues."""
    angle = np.linalg.norm(w, axis=1)
    k = w / np.where(angle > 0, angle, 1.0)[:, None]
    cross = np.zeros((len(w), 3, 3))
    cross[:, 0, 1], cross[:, 0, 2], cross[:, 1, 2] = -k[:, 2], k[:, 1], -k[:, 0]
    cross -= cross.transpose(0, 2, 1)
    return (np.eye(3) + np.sin(angle)[:, None, None] * cross
            + (1.0 - np.cos(angle))[:, None, None] * (cross @ cross))


def _pixels(p: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pixels (K x N) of camera-frame vectors ``v`` (N x 3) through each row of
    parameters ``p`` (K x 7): rotation vector (3), focal length, principal point (2), k1
    (the camera's lens model's first term)."""
    w = v @ _rotation(p[:, :3]).transpose(0, 2, 1)
    u, t = w[..., 0] / w[..., 2], w[..., 1] / w[..., 2]
    scale = p[:, 3:4] * (1.0 + p[:, 6:7] * (u * u + t * t))
    return p[:, 4:5] + u * scale, p[:, 5:6] + t * scale


def _centre(p: np.ndarray, x: float, y: float) -> np.ndarray:
    """Tangent-plane direction (u, v) in the answer's camera frame of pixel (x, y)
    through parameters ``p`` (k1 inverted by fixed-point steps: small near the centre)."""
    du, dv = (x - p[4]) / p[3], (y - p[5]) / p[3]
    u, t = du, dv
    for _ in range(8):
        s = 1.0 + p[6] * (u * u + t * t)
        u, t = du / s, dv / s
    w = _rotation(p[None, :3])[0].T @ np.array([u, t, 1.0])
    return w[:2] / w[2]


def _pairs(p, v, x, y, limit):
    """Mutually nearest (spot, catalog star) pairs within ``limit`` px."""
    px, py = (a[0] for a in _pixels(p[None], v))
    d = np.hypot(x[:, None] - px[None, :], y[:, None] - py[None, :])
    star = d.argmin(axis=1)
    ok = (d[np.arange(len(x)), star] <= limit) & (d.argmin(axis=0)[star] == np.arange(len(x)))
    return np.flatnonzero(ok), star[ok]


def _jacobian(p, v, x, y):
    """Residuals (x then y, px) at ``p`` and their forward-difference Jacobian, every
    parameter set in one batch."""
    steps = _STEPS * np.where(np.arange(7) == 3, p[3], 1.0)
    px, py = _pixels(p + np.vstack([np.zeros(7), np.diag(steps)]), v)
    res = np.concatenate([px - x, py - y], axis=1)
    return res[0], ((res[1:] - res[0]) / steps[:, None]).T


def _fit(p, v, x, y, free_k1: bool):
    """Levenberg-Marquardt from ``p`` (k1 held unless ``free_k1``): (parameters,
    residuals, Jacobian at the end)."""
    r, jac = _jacobian(p, v, x, y)
    damping = DAMPING
    held = np.arange(7) == 6 if not free_k1 else np.zeros(7, bool)
    for _ in range(ITERATIONS):
        norm = np.linalg.norm(jac, axis=0)
        norm[(norm == 0) | held] = 1.0
        a = np.where(held, 0.0, jac / norm)
        h = a.T @ a
        step = np.linalg.solve(h + damping * np.diag(np.diag(h)) + 1e-12 * np.eye(7),
                               -a.T @ r) / norm
        trial, trial_jac = _jacobian(p + step, v, x, y)
        if trial @ trial < r @ r:
            p, r, jac, damping = p + step, trial, trial_jac, damping / 10.0
            if np.all(np.abs(step) <= 1e-7 * (1.0 + np.abs(p))):
                break
        else:
            damping *= 10.0
            if damping > 1e8 or np.all(np.abs(step) <= 1e-7 * (1.0 + np.abs(p))):
                break
    return p, r, jac


def k1_statistic(r, jac) -> float:
    """k1's score test at a fit that held it: the efficient score squared over the
    residuals' variance times k1's information left after the other six parameters."""
    others, k1 = jac[:, :6], jac[:, 6]
    explained = np.linalg.lstsq(others, k1, rcond=None)[0]
    info = k1 @ k1 - (others.T @ k1) @ explained
    score = k1 @ r - (others.T @ r) @ explained
    return score * score / ((r @ r) / (len(r) - 6) * info)


def fit_rounds(p, v, x, y, radius_px):
    """The refit's rounds from ``p``: (parameters, residuals, Jacobian) of the last round,
    or None when a round pairs fewer than MIN_PAIRS; the rounds that free k1 skipped
    where its score at the last fit is within K1_CHI2."""
    r = jac = None
    held_before = False
    for factor, free_k1 in ROUNDS:
        if free_k1 and held_before and k1_statistic(r, jac) <= K1_CHI2:
            return p, r, jac
        held_before = not free_k1
        spots, stars = _pairs(p, v, x, y, factor * radius_px)
        if len(spots) < MIN_PAIRS:
            return None
        p, r, jac = _fit(p, v[stars], x[spots], y[spots], free_k1)
    return p, r, jac


def pairs(p, v, x, y, limit):
    """Mutually nearest (spot, catalog star) pairs within ``limit`` px."""
    return _pairs(p, v, x, y, limit)


def centre(p, x, y):
    """Tangent-plane direction of pixel (x, y) through ``p``."""
    return _centre(p, x, y)
