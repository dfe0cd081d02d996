"""Compiled arithmetic of verification: Wahba's problem, the catalog projected through an
attitude and a lens, observed stars paired with it, and the refinement loop.

A frame has tens of stars, so numpy or scipy on them is dominated by per-call overhead;
these kernels do a whole step per call. The camera comes in as ``geometry``:
``[f_px, cx, cy, width, height, k1, k2, k3, max_r2]`` (:func:`startrack.camera.geometry`),
and the projection is :meth:`startrack.camera.Camera.vector_to_pixel` followed by
:meth:`~startrack.camera.Camera.in_image`, operation for operation.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from startrack.database.cone import cone_rows


@njit(cache=True)
def _rotate(a, v, p, q):
    """One Jacobi rotation of the symmetric 4 x 4 ``a`` zeroing a[p, q], accumulated in v."""
    theta = (a[q, q] - a[p, p]) / (2.0 * a[p, q])
    t = (1.0 if theta >= 0.0 else -1.0) / (abs(theta) + math.sqrt(theta * theta + 1.0))
    c = 1.0 / math.sqrt(t * t + 1.0)
    s = t * c
    for r in range(4):
        arp, arq = a[r, p], a[r, q]
        a[r, p], a[r, q] = c * arp - s * arq, s * arp + c * arq
    for r in range(4):
        apr, aqr = a[p, r], a[q, r]
        a[p, r], a[q, r] = c * apr - s * aqr, s * apr + c * aqr
    for r in range(4):
        vrp, vrq = v[r, p], v[r, q]
        v[r, p], v[r, q] = c * vrp - s * vrq, s * vrp + c * vrq


@njit(cache=True)
def _top_eigenvector(k):
    """The eigenvector of the largest eigenvalue of a symmetric 4 x 4 matrix (cyclic
    Jacobi: accurate to rounding however close the other eigenvalues come, which a
    narrow field makes them)."""
    a = k.copy()
    v = np.eye(4)
    scale = a[0, 0] ** 2 + a[1, 1] ** 2 + a[2, 2] ** 2 + a[3, 3] ** 2
    for _ in range(30):
        off = 0.0
        for p in range(3):
            for q in range(p + 1, 4):
                off += a[p, q] * a[p, q]
        if off <= 1e-30 * scale:
            break
        for p in range(3):
            for q in range(p + 1, 4):
                if a[p, q] != 0.0:
                    _rotate(a, v, p, q)
    best = 0
    for i in range(1, 4):
        if a[i, i] > a[best, best]:
            best = i
    return v[:, best]


@njit(cache=True)
def wahba(cam, sky):
    """The rotation matrix R minimising sum |sky_k - R cam_k|^2 over (m, 3) vector pairs:
    Davenport's q-method, the quaternion maximising q^T K q, by a Jacobi eigen-solve
    (no SVD call: this runs for every hypothesis)."""
    b = np.zeros((3, 3))
    for n in range(cam.shape[0]):
        for i in range(3):
            for j in range(3):
                b[i, j] += sky[n, i] * cam[n, j]
    sigma = b[0, 0] + b[1, 1] + b[2, 2]
    k = np.empty((4, 4))
    k[0, 0] = sigma
    k[0, 1] = k[1, 0] = b[1, 2] - b[2, 1]
    k[0, 2] = k[2, 0] = b[2, 0] - b[0, 2]
    k[0, 3] = k[3, 0] = b[0, 1] - b[1, 0]
    for i in range(3):
        for j in range(3):
            k[i + 1, j + 1] = b[i, j] + b[j, i] - (sigma if i == j else 0.0)
    q = _top_eigenvector(k)
    w, x, y, z = q[0], -q[1], -q[2], -q[3]  # K's vector part is of the inverse rotation
    r = np.empty((3, 3))
    r[0, 0], r[0, 1], r[0, 2] = 1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)
    r[1, 0], r[1, 1], r[1, 2] = 2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)
    r[2, 0], r[2, 1], r[2, 2] = 2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)
    return r


@njit(cache=True)
def fits_within(cam, sky, matrix, cos_radius):
    """Whether every pair lies within the match radius of the other at ``matrix``."""
    for k in range(cam.shape[0]):
        dot = 0.0
        for i in range(3):
            dot += (matrix[i, 0] * cam[k, 0] + matrix[i, 1] * cam[k, 1]
                    + matrix[i, 2] * cam[k, 2]) * sky[k, i]
        if dot < cos_radius:
            return False
    return True


@njit(cache=True)
def project(vectors, matrix, geometry, margin):
    """Pixel positions of catalog vectors (n, 3) at the attitude ``matrix`` (camera to sky)
    and whether each falls in the image widened by ``margin`` pixels (negative: narrowed).
    A star behind the camera, or beyond the radius where the lens model folds back, is out."""
    f, cx, cy, width, height = geometry[0], geometry[1], geometry[2], geometry[3], geometry[4]
    k1, k2, k3, max_r2 = geometry[5], geometry[6], geometry[7], geometry[8]
    n = vectors.shape[0]
    px = np.zeros(n)
    py = np.zeros(n)
    inside = np.zeros(n, np.bool_)
    lo_x, hi_x = -0.5 - margin, width - 0.5 + margin
    lo_y, hi_y = -0.5 - margin, height - 0.5 + margin
    for i in range(n):
        a, b, c = vectors[i, 0], vectors[i, 1], vectors[i, 2]  # R^T v: in the camera frame
        vx = a * matrix[0, 0] + b * matrix[1, 0] + c * matrix[2, 0]
        vy = a * matrix[0, 1] + b * matrix[1, 1] + c * matrix[2, 1]
        vz = a * matrix[0, 2] + b * matrix[1, 2] + c * matrix[2, 2]
        if vz <= 1e-12:
            continue
        u, w = vx / vz, vy / vz
        r2 = u * u + w * w
        if not r2 < max_r2:
            continue
        s = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
        px[i], py[i] = cx + f * (u * s), cy + f * (w * s)
        inside[i] = lo_x <= px[i] <= hi_x and lo_y <= py[i] <= hi_y
    return px, py, inside


GRID_CELLS = 64  # cells per axis at most: a frame's hundreds of stars spread thin


@njit(cache=True)
def _grid(cx, cy, x0, y0, size, nx, ny):
    """Catalog positions bucketed in square cells: (cell start offsets, rows by cell)."""
    start = np.zeros(nx * ny + 1, np.int64)
    cell = np.empty(cx.shape[0], np.int64)
    for j in range(cx.shape[0]):
        cell[j] = int((cy[j] - y0) / size) * nx + int((cx[j] - x0) / size)
        start[cell[j] + 1] += 1
    for c in range(nx * ny):
        start[c + 1] += start[c]
    fill = start[:-1].copy()
    order = np.empty(cx.shape[0], np.int64)
    for j in range(cx.shape[0]):
        order[fill[cell[j]]] = j
        fill[cell[j]] += 1
    return start, order


@njit(cache=True)
def _nearest(ox, oy, cx, cy, radius_px):
    """Per observed star, its nearest catalog star if within ``radius_px`` (else -1; on a
    tie the lower index) and the squared distance: a grid of cells no smaller than the
    radius, so that only the 3 x 3 cells around a star can hold its match."""
    n, m = ox.shape[0], cx.shape[0]
    nearest = np.full(n, -1, np.int64)
    dist2 = np.full(n, np.inf)
    if n == 0 or m == 0:
        return nearest, dist2
    x0, y0 = min(ox.min(), cx.min()), min(oy.min(), cy.min())
    x1, y1 = max(ox.max(), cx.max()), max(oy.max(), cy.max())
    size = max(radius_px, (x1 - x0) / GRID_CELLS, (y1 - y0) / GRID_CELLS, 1e-9)
    nx, ny = int((x1 - x0) / size) + 1, int((y1 - y0) / size) + 1
    start, order = _grid(cx, cy, x0, y0, size, nx, ny)
    r2 = radius_px * radius_px
    for i in range(n):
        gx, gy = int((ox[i] - x0) / size), int((oy[i] - y0) / size)
        best, best_d = -1, np.inf
        for yy in range(max(gy - 1, 0), min(gy + 2, ny)):
            for xx in range(max(gx - 1, 0), min(gx + 2, nx)):
                c = yy * nx + xx
                for q in range(start[c], start[c + 1]):
                    j = order[q]
                    d = (ox[i] - cx[j]) ** 2 + (oy[i] - cy[j]) ** 2
                    if d < best_d or (d == best_d and j < best):
                        best, best_d = j, d
        if best >= 0 and best_d <= r2:
            nearest[i], dist2[i] = best, best_d
    return nearest, dist2


@njit(cache=True)
def nearest_matches(ox, oy, cx, cy, radius_px):
    """Pair each observed star (ox, oy) with its nearest catalog star (cx, cy) within
    ``radius_px``; a catalog star claimed by several keeps the nearest (on a tie, the
    first). Returns (observed rows ascending, catalog positions)."""
    nearest, dist2 = _nearest(ox, oy, cx, cy, radius_px)
    owner = np.full(cx.shape[0], -1, np.int64)
    for i in range(ox.shape[0]):
        j = nearest[i]
        if j >= 0 and (owner[j] < 0 or dist2[i] < dist2[owner[j]]):
            owner[j] = i
    keep = np.zeros(ox.shape[0], np.bool_)
    for i in range(ox.shape[0]):
        keep[i] = nearest[i] >= 0 and owner[nearest[i]] == i
    rows = np.flatnonzero(keep)
    return rows, nearest[rows]


@njit(cache=True)
def match(vectors, matrix, ox, oy, geometry, radius):
    """Observed stars paired with the catalog vectors that fall in the image widened by
    ``radius`` (a star just beyond the edge can still be an observed star's) at ``matrix``:
    (observed index ascending, vector position, how many vectors fall in it)."""
    px, py, inside = project(vectors, matrix, geometry, radius)
    where = np.flatnonzero(inside)
    obs_idx, pos = nearest_matches(ox, oy, px[where], py[where], radius)
    return obs_idx, where[pos], where.shape[0]


@njit(cache=True)
def _confirmed(obs_idx, hyp_obs, n_obs):
    chosen = np.zeros(n_obs, np.bool_)
    chosen[hyp_obs] = True
    count = 0
    for i in obs_idx:
        count += not chosen[i]
    return count


@njit(cache=True)
def first_match(obs_vectors, ox, oy, hyp_obs, hyp_sky, catalog, cone_order, cone_z,
                cone_radius, geometry, radius, cos_radius):
    """The first test of a hypothesis, in one call: its attitude (Wahba), each of its
    stars within the match radius, then the catalog cone around that attitude matched to
    the frame. Returns (fits, matrix, cone rows, cone vectors, observed index, cone
    position, catalog stars in the image, matches outside the hypothesis)."""
    matrix = wahba(obs_vectors[hyp_obs], hyp_sky)
    rows = np.zeros(0, np.int64)
    vectors = np.zeros((0, 3))
    if not fits_within(obs_vectors[hyp_obs], hyp_sky, matrix, cos_radius):
        return False, matrix, rows, vectors, rows, rows, 0, 0
    rows = cone_rows(catalog, cone_order, cone_z, matrix[:, 2].copy(), cone_radius)
    vectors = np.empty((rows.shape[0], 3))
    for i in range(rows.shape[0]):
        vectors[i] = catalog[rows[i]]
    obs_idx, pos, n_in = match(vectors, matrix, ox, oy, geometry, radius)
    return (True, matrix, rows, vectors, obs_idx, pos, n_in,
            _confirmed(obs_idx, hyp_obs, ox.shape[0]))


@njit(cache=True)
def first_match_fixed(obs_vectors, ox, oy, hyp_obs, hyp_sky, vectors, geometry, radius,
                      cos_radius):
    """:func:`first_match` over given catalog vectors instead of a cone: (fits, matrix,
    observed index, vector position, catalog stars in the image, matches outside)."""
    matrix = wahba(obs_vectors[hyp_obs], hyp_sky)
    none = np.zeros(0, np.int64)
    if not fits_within(obs_vectors[hyp_obs], hyp_sky, matrix, cos_radius):
        return False, matrix, none, none, 0, 0
    obs_idx, pos, n_in = match(vectors, matrix, ox, oy, geometry, radius)
    return True, matrix, obs_idx, pos, n_in, _confirmed(obs_idx, hyp_obs, ox.shape[0])


@njit(cache=True)
def refine(obs_vectors, ox, oy, vectors, geometry, radius, capture, obs_m, pos_m,
           max_rounds):
    """Refit on every matched star and match again until the matched set stops changing;
    when a plain refit changes nothing, refit once on the matches within ``capture``
    match radii and keep that only if it then matches more stars (see
    :func:`startrack.verify.refine`). Returns (observed index, vector position, matrix)."""
    matrix = wahba(obs_vectors[obs_m], vectors[pos_m])
    for _ in range(max_rounds):
        obs_new, pos_new, _ = match(vectors, matrix, ox, oy, geometry, radius)
        changed = obs_new.shape[0] > obs_m.shape[0] or (
            obs_new.shape[0] == obs_m.shape[0]
            and not (np.all(obs_new == obs_m) and np.all(pos_new == pos_m)))
        if not changed:
            obs_w, pos_w, _ = match(vectors, matrix, ox, oy, geometry, capture * radius)
            if obs_w.shape[0] < 2:
                break
            wide = wahba(obs_vectors[obs_w], vectors[pos_w])
            obs_new, pos_new, _ = match(vectors, wide, ox, oy, geometry, radius)
            if obs_new.shape[0] <= obs_m.shape[0]:
                break
        obs_m, pos_m = obs_new, pos_new
        matrix = wahba(obs_vectors[obs_m], vectors[pos_m])
    return obs_m, pos_m, matrix


@njit(cache=True)
def matrix_to_quaternion(m):
    """Unit quaternion of a rotation matrix, scalar LAST ``[x, y, z, w]`` as scipy's
    ``Rotation.from_quat`` takes it fastest, w >= 0 (Shepperd's method)."""
    q = np.empty(4)
    tr = m[0, 0] + m[1, 1] + m[2, 2]
    if tr >= m[0, 0] and tr >= m[1, 1] and tr >= m[2, 2]:
        q[0] = 1.0 + tr
        q[1], q[2], q[3] = m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1]
    elif m[0, 0] >= m[1, 1] and m[0, 0] >= m[2, 2]:
        q[0], q[1] = m[2, 1] - m[1, 2], 1.0 + 2.0 * m[0, 0] - tr
        q[2], q[3] = m[0, 1] + m[1, 0], m[0, 2] + m[2, 0]
    elif m[1, 1] >= m[2, 2]:
        q[0], q[1] = m[0, 2] - m[2, 0], m[0, 1] + m[1, 0]
        q[2], q[3] = 1.0 + 2.0 * m[1, 1] - tr, m[1, 2] + m[2, 1]
    else:
        q[0], q[1] = m[1, 0] - m[0, 1], m[0, 2] + m[2, 0]
        q[2], q[3] = m[1, 2] + m[2, 1], 1.0 + 2.0 * m[2, 2] - tr
    q /= np.sqrt((q * q).sum())
    if q[0] < 0.0:
        q = -q
    return np.array([q[1], q[2], q[3], q[0]])


def warm_up() -> None:
    """Compile (or load from numba's cache) every kernel on a tiny input, so that the
    first frame is not timed with the compilation."""
    v = np.array([[0.0, 0.0, 1.0], [0.01, 0.0, 1.0], [0.0, 0.01, 1.0]])
    v /= np.sqrt((v * v).sum(axis=1))[:, None]
    xy = np.array([1.0, 2.0, 3.0])
    geometry = np.array([100.0, 1.0, 1.0, 4.0, 4.0, 0.0, 0.0, 0.0, np.inf])
    m = wahba(v, v)
    fits_within(v, v, m, 0.5)
    idx = np.arange(3)
    refine(v, xy, xy, v, geometry, 1.0, 3.0, idx, idx, 2)
    matrix_to_quaternion(m)
