"""How far an answer moves when its camera is refitted: whether the camera fits the frame.

An answer through a camera that does not fit (a principal point at (100, 900) declared
centred) and an answer whose stars the final labelling was wary of (saturated spots,
thousands of false spots, a little lens distortion) can both label few of the bright
spots. They differ in what the bright spots say once the camera is free: the brightest
spots are paired with the brightest catalog stars the answer puts in the image, and the
attitude, focal length, principal point and k1 are fitted to those pairs. Where the
camera did not fit, the image centre's direction moves by about the answer's own error
(simulated offset principal points: the move is within 0.1 px of the true error); where it
fitted, it stays within the fit's own uncertainty. :func:`refit_camera` returns that move
and its 1-sigma (from the fit's covariance), with the spots the refitted camera explains.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: the brightest spots paired, and the brightest catalog stars in the image they pair with
#: (more than the 20 judged: a bright spot's star may be fainter in the catalog's band)
SPOTS = 40
CATALOG_STARS = 60
#: fewer pairs than this fit no 7-parameter camera worth believing
MIN_PAIRS = 8
#: each round's pairing radius in match radii, wide first (the answer's camera may put a
#: star several pixels off), and whether k1 is free: fixed at first, as k1 can trade for
#: an offset principal point and lead the fit into a false minimum (a corner principal
#: point taken for k1 = -0.44, the move then 0.5 px for an answer 3.4 px off)
ROUNDS = ((3.0, False), (2.0, False), (1.0, False), (1.0, True), (1.0, True))
#: Levenberg-Marquardt steps per round at most: the principal point and the attitude
#: nearly trade off, so a few plain Gauss-Newton steps stop short (and an unconverged fit
#: overstates the move's uncertainty)
ITERATIONS = 40
DAMPING = 1e-3  # the first step's damping, relative to the curvature
#: finite-difference steps: rotation (rad), focal length (fraction), centre (px), k1
_STEPS = np.array([1e-6, 1e-6, 1e-6, 1e-6, 1e-3, 1e-3, 1e-6])


@dataclass(frozen=True)
class Refit:
    """The refitted camera's verdict: which of the brightest spots it explains (indices,
    ascending), and how far (px) the image centre's direction moved, with its 1-sigma."""

    explained: np.ndarray
    shift_px: float
    sigma_px: float


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
            if damping > 1e8:
                break
    return p, r, jac


def refit_camera(rotation, x, y, camera, catalog, radius_px: float,
                 sigma_px: float) -> Refit | None:
    """:class:`Refit` of an answer (``rotation`` through ``camera``, the spots at ``x``,
    ``y`` brightest first, matched within ``radius_px``; ``sigma_px``: the least
    centroid error the residuals are taken to have); None when too few pairs fit."""
    boresight = rotation.apply(np.array([0.0, 0.0, 1.0]))
    near = np.flatnonzero(catalog.vectors @ boresight > math.cos(
        math.radians(camera.half_diagonal_deg)))
    v = rotation.inv().apply(catalog.vectors[near])
    cx, cy, front = camera.vector_to_pixel(v)
    inside = np.flatnonzero(front & camera.in_image(cx, cy))
    v = v[inside[np.argsort(catalog.mag[near[inside]], kind="stable")][:CATALOG_STARS]]
    return refit_stars(v, np.asarray(x[:SPOTS], np.float64), np.asarray(y[:SPOTS], np.float64),
                       camera, radius_px, sigma_px)


def refit_stars(v: np.ndarray, x: np.ndarray, y: np.ndarray, camera, radius_px: float,
                sigma_px: float) -> Refit | None:
    """:func:`refit_camera` of catalog stars at camera-frame vectors ``v`` (brightest
    first) and spots at ``x``, ``y`` (brightest first)."""
    k1 = camera.distortion.k1 if camera.distortion is not None else 0.0
    p = np.array([0.0, 0.0, 0.0, camera.f_px, camera.cx, camera.cy, k1])
    for factor, free_k1 in ROUNDS:
        spots, stars = _pairs(p, v, x, y, factor * radius_px)
        if len(spots) < MIN_PAIRS:
            return None
        p, r, jac = _fit(p, v[stars], x[spots], y[spots], free_k1)
    variance = max(float(r @ r) / max(1, len(r) - 7), sigma_px * sigma_px)
    cov = variance * np.linalg.pinv(jac.T @ jac)
    cx0, cy0 = (camera.width - 1) / 2.0, (camera.height - 1) / 2.0
    given = camera.pixel_to_vector(np.array([cx0]), np.array([cy0]))[0]
    centre = _centre(p, cx0, cy0)
    grad = np.empty((2, 7))
    for k in range(7):
        q = p.copy()
        q[k] += math.sqrt(max(cov[k, k], 0.0)) * 1e-3 + 1e-12
        grad[:, k] = (_centre(q, cx0, cy0) - centre) / (q[k] - p[k])
    shift = float(np.hypot(*(centre - given[:2] / given[2]))) * camera.f_px
    sigma = math.sqrt(max(float(np.trace(grad @ cov @ grad.T)), 0.0)) * camera.f_px
    spots, _ = _pairs(p, v, x, y, radius_px)
    return Refit(spots, shift, sigma)
