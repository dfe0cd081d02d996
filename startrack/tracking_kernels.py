"""Compiled kernels of the tracking stage: pair observed stars with the catalog stars
projected at a prediction, vote on their displacement, rotation matrix <-> rotation vector
(numba; a frame has tens of stars, and numpy or scipy on so few is dominated by per-call
overhead). The projection is verification's own
(:func:`startrack.matching.verify_kernels.project`), lens included.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from startrack.matching import verify_kernels
from startrack.matching.labelling_kernels import warm_up as _warm_up_labelling
from startrack.matching.nearest_kernels import pairs_within
from startrack.matching.verify_kernels import project


@njit(cache=True)
def window_pairs(vectors, matrix, ox, oy, geometry, window):
    """Every (observed, catalog position) pair within ``window`` pixels at ``matrix``,
    by observed then catalog position, with the displacement catalog - observed."""
    px, py, inside = project(vectors, matrix, geometry, window)
    sel = np.flatnonzero(inside)
    oi, pos, _, _ = pairs_within(ox, oy, px[sel], py[sel], window * window)
    cj = sel[pos]
    dx = np.empty(oi.shape[0])
    dy = np.empty(oi.shape[0])
    for k in range(oi.shape[0]):
        dx[k], dy[k] = px[cj[k]] - ox[oi[k]], py[cj[k]] - oy[oi[k]]
    return oi, cj, dx, dy


@njit(cache=True)
def consistent(oi, ci, dx, dy, vote_tol, tol):
    """Indices of the pairs that agree on one displacement: the pair whose displacement
    the most distinct observed stars share within ``vote_tol`` px (the densest spot; ties:
    the smaller displacement), then, within ``tol`` px of it (which allows for the spread
    a roll error makes), per observed star the pair nearest it, each catalog star once
    (nearest wins, ties: the lower observed index). Sorted by the distance of their
    displacement from the winner's."""
    p = oi.shape[0]
    v2 = vote_tol * vote_tol
    t2 = tol * tol
    seen = np.full(oi.max() + 1 if p else 1, -1, np.int64)
    best, best_votes, best_d = -1, -1, np.inf
    for i in range(p):
        votes = 0
        for j in range(p):
            if (dx[i] - dx[j]) ** 2 + (dy[i] - dy[j]) ** 2 <= v2 and seen[oi[j]] != i:
                seen[oi[j]] = i
                votes += 1
        d = dx[i] ** 2 + dy[i] ** 2
        if votes > best_votes or (votes == best_votes and d < best_d):
            best, best_votes, best_d = i, votes, d
    n_obs = seen.shape[0]
    pick = np.full(n_obs, -1, np.int64)
    dist = np.full(n_obs, np.inf)
    for j in range(p):
        d = (dx[best] - dx[j]) ** 2 + (dy[best] - dy[j]) ** 2
        if d <= t2 and d < dist[oi[j]]:
            pick[oi[j]], dist[oi[j]] = j, d
    keep = np.zeros(n_obs, np.bool_)
    for o in range(n_obs):
        if pick[o] < 0:
            continue
        keep[o] = True
        for o2 in range(o):  # a catalog star claimed twice: the nearer (earlier) keeps it
            if keep[o2] and ci[pick[o2]] == ci[pick[o]]:
                if dist[o] < dist[o2]:
                    keep[o2] = False
                else:
                    keep[o] = False
                break
    chosen = pick[keep]
    # Nearest the winning displacement first: true pairs cluster there, chance pairs
    # inside a wide window spread over it.
    return chosen[np.argsort(dist[keep], kind="mergesort")]


@njit(cache=True)
def consistent_pairs(vectors, matrix, ox, oy, geometry, window, vote_tol, tol):
    """:func:`window_pairs` then :func:`consistent` in one call: the consistent pairs'
    observed indices and catalog positions, and how many pairs the window held (the
    vote needs three)."""
    oi, cj, dx, dy = window_pairs(vectors, matrix, ox, oy, geometry, window)
    if oi.shape[0] < 3:
        return oi[:0], cj[:0], oi.shape[0]
    keep = consistent(oi, cj, dx, dy, vote_tol, tol)
    return oi[keep], cj[keep], oi.shape[0]


@njit(cache=True)
def predict_attitude(rot_a, rot_b, gap, steps, sig_a, sig_b, unknown_rate, accel_fraction,
                     rate_floor):
    """The attitude ``steps`` frames after ``rot_b`` (camera to sky) and its 1-sigma error:
    the per-frame rotation estimated from ``rot_a``, ``gap`` frames before ``rot_b``
    (R_b = R_a exp(w gap), in the camera frame), carried forward; with ``gap`` 0 there is
    no rate yet and the error grows by ``unknown_rate`` per frame. The rate's own error
    per frame: the two attitudes' errors over the gap, ``accel_fraction`` of the rate
    (angular acceleration) and a floor (jitter)."""
    rate = np.zeros(3)
    sig_w = unknown_rate
    if gap > 0:
        rate = rotation_log(rot_a.T @ rot_b) / gap
        sig_w = (math.hypot(sig_a, sig_b) / gap + accel_fraction * np.linalg.norm(rate)
                 + rate_floor)
    return rot_b @ rotation_exp(rate * steps), sig_b + steps * sig_w


@njit(cache=True)
def rotation_exp(rotvec: np.ndarray) -> np.ndarray:
    """The rotation matrix of a rotation vector (Rodrigues), without scipy's overhead."""
    angle = float(np.linalg.norm(rotvec))
    if angle < 1e-15:
        return np.eye(3)
    k = rotvec / angle
    kx = np.zeros((3, 3))
    kx[0, 1], kx[0, 2], kx[1, 2] = -k[2], k[1], -k[0]
    kx[1, 0], kx[2, 0], kx[2, 1] = k[2], -k[1], k[0]
    return np.eye(3) + math.sin(angle) * kx + (1.0 - math.cos(angle)) * (kx @ kx)


@njit(cache=True)
def rotation_log(matrix: np.ndarray) -> np.ndarray:
    """The rotation vector of a rotation matrix (angles well below pi: frame to frame)."""
    cos = min(1.0, max(-1.0, (float(np.trace(matrix)) - 1.0) / 2.0))
    angle = math.acos(cos)
    axis = np.empty(3)
    axis[0] = matrix[2, 1] - matrix[1, 2]
    axis[1] = matrix[0, 2] - matrix[2, 0]
    axis[2] = matrix[1, 0] - matrix[0, 1]
    if angle < 1e-7:
        return axis / 2.0
    return axis * (angle / (2.0 * math.sin(angle)))


def warm_up() -> None:
    """Compile (or load from numba's cache) every kernel on a tiny input, so that the first
    frame of a sequence is not timed with the compilation."""
    v = np.array([[0.0, 0.0, 1.0], [0.01, 0.0, 1.0], [0.0, 0.01, 1.0]])
    v /= np.sqrt((v * v).sum(axis=1))[:, None]
    m, xy = np.eye(3), np.array([1.0, 2.0, 3.0])
    geometry = np.array([100.0, 1.0, 1.0, 4.0, 4.0, 0.0, 0.0, 0.0, np.inf])
    verify_kernels.warm_up()
    oi, cj, dx, dy = window_pairs(v, m, xy, xy, geometry, 50.0)
    consistent(oi, cj, dx, dy, 1.0, 2.0)
    consistent_pairs(v, m, xy, xy, geometry, 50.0, 1.0, 2.0)
    rotation_log(rotation_exp(np.array([0.0, 0.0, 0.1])))
    predict_attitude(m, m, 1, 1, 1e-5, 1e-5, 1e-3, 0.1, 1e-4)
    _warm_up_labelling()  # a tracked frame's labelling
