"""Compiled kernels of the tracking stage: project catalog stars through an attitude and
pair them with observed stars, vote on their displacement, Wahba's problem, rotation
matrix <-> quaternion / rotation vector (numba; a frame has tens of stars, and numpy or
scipy on so few is dominated by per-call overhead).

:func:`project_match` reproduces :meth:`startrack.verify._Projector.match` exactly: the
catalog stars in front of the camera and inside the image widened by ``margin`` pixels
count as "in the image"; each observed star takes its nearest such star within
``radius``; a catalog star claimed by several keeps the nearest (ties: the lower observed
index). ``tests/test_tracking.py`` checks the two agree.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from startrack.labelling_kernels import warm_up as _warm_up_labelling


@njit(cache=True)
def _project(vectors, matrix, f, cx, cy, width, height, margin):
    n = vectors.shape[0]
    px = np.empty(n)
    py = np.empty(n)
    inside = np.zeros(n, np.bool_)
    lo_x, hi_x = -0.5 - margin, width - 0.5 + margin
    lo_y, hi_y = -0.5 - margin, height - 0.5 + margin
    for i in range(n):
        # R^T v: the catalog vector in the camera frame.
        a, b, c = vectors[i, 0], vectors[i, 1], vectors[i, 2]
        vx = a * matrix[0, 0] + b * matrix[1, 0] + c * matrix[2, 0]
        vy = a * matrix[0, 1] + b * matrix[1, 1] + c * matrix[2, 1]
        vz = a * matrix[0, 2] + b * matrix[1, 2] + c * matrix[2, 2]
        if vz > 1e-12:
            px[i] = cx + f * vx / vz
            py[i] = cy + f * vy / vz
            inside[i] = lo_x <= px[i] <= hi_x and lo_y <= py[i] <= hi_y
    return px, py, inside


@njit(cache=True)
def project_match(vectors, matrix, ox, oy, f, cx, cy, width, height, margin, radius):
    """(observed index, catalog position, number of catalog stars in the image)."""
    px, py, inside = _project(vectors, matrix, f, cx, cy, width, height, margin)
    n_obs, n_cat = ox.shape[0], vectors.shape[0]
    n_in = 0
    for j in range(n_cat):
        n_in += inside[j]
    owner = np.full(n_cat, -1, np.int64)
    best = np.full(n_cat, np.inf)
    r2 = radius * radius
    for i in range(n_obs):
        near, d_near = -1, np.inf
        for j in range(n_cat):
            if inside[j]:
                d = (ox[i] - px[j]) ** 2 + (oy[i] - py[j]) ** 2
                if d < d_near:
                    near, d_near = j, d
        if near >= 0 and d_near <= r2 and d_near < best[near]:
            owner[near], best[near] = i, d_near
    taken = np.full(n_obs, -1, np.int64)
    for j in range(n_cat):
        if owner[j] >= 0:
            taken[owner[j]] = j
    k = 0
    for i in range(n_obs):
        k += taken[i] >= 0
    obs_idx = np.empty(k, np.int64)
    cat_pos = np.empty(k, np.int64)
    k = 0
    for i in range(n_obs):
        if taken[i] >= 0:
            obs_idx[k], cat_pos[k] = i, taken[i]
            k += 1
    return obs_idx, cat_pos, n_in


@njit(cache=True)
def window_pairs(vectors, matrix, ox, oy, f, cx, cy, width, height, window):
    """Every (observed, catalog position) pair within ``window`` pixels at ``matrix``,
    with the displacement catalog - observed."""
    px, py, inside = _project(vectors, matrix, f, cx, cy, width, height, window)
    n_obs, n_cat = ox.shape[0], vectors.shape[0]
    w2 = window * window
    count = 0
    for i in range(n_obs):
        for j in range(n_cat):
            if inside[j] and (px[j] - ox[i]) ** 2 + (py[j] - oy[i]) ** 2 <= w2:
                count += 1
    oi = np.empty(count, np.int64)
    cj = np.empty(count, np.int64)
    dx = np.empty(count)
    dy = np.empty(count)
    k = 0
    for i in range(n_obs):
        for j in range(n_cat):
            if inside[j] and (px[j] - ox[i]) ** 2 + (py[j] - oy[i]) ** 2 <= w2:
                oi[k], cj[k], dx[k], dy[k] = i, j, px[j] - ox[i], py[j] - oy[i]
                k += 1
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
    project_match(v, m, xy, xy, 100.0, 1.0, 1.0, 4.0, 4.0, 1.0, 1.0)
    oi, cj, dx, dy = window_pairs(v, m, xy, xy, 100.0, 1.0, 1.0, 4.0, 4.0, 50.0)
    consistent(oi, cj, dx, dy, 1.0, 2.0)
    rotation_log(rotation_exp(np.array([0.0, 0.0, 0.1])))
    _warm_up_labelling()  # a tracked frame's labelling
