"""Compiled planar-triangle lookups: the catalog triangles of one observed triple.

The k-vector range on area, the polar-moment filter and the vertex mapping by side
lengths with the mirror refused (see :mod:`startrack.matchers.planar_triangle`), each
number computed as the numpy reference computes it (the same operations in the same
order, tested to the bit), so that the compiled search proposes what the reference did.
Per frame, the area window, polar filter and catalog side lengths of a triple are worked
out once for all six vertex orders (``kept``), the mapping once per vertex order
(``store``); both memos grow as they fill.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
from numba import njit

from startrack.database.sort_kernels import kvector_range
from startrack.matching.feature_kernels import features

#: ``state`` entries: database candidates (area window sizes), triangles the polar-moment
#: filter kept, pivots, lookups made, rows used in the two memos.
CANDIDATES, POLAR_KEPT, PIVOTS, LOOKUPS, KEPT_FILL, STORE_FILL = range(6)

# The six vertex orders; the odd ones reverse the handedness (the triple product's sign).
PERMS = np.array(list(itertools.permutations(range(3))), np.int64)
ODD = np.array([False, True, True, False, False, True])
# The side between vertices i and j of a triangle, by i + j: (0, 1) -> 0, (0, 2) -> 2,
# (1, 2) -> 1 (sides are |v0 - v1|, |v1 - v2|, |v0 - v2|).
_SIDE_OF_SUM = np.array([-1, 0, 2, 1], np.int64)


@njit(cache=True, inline="always")
def _dist(u, w):
    # np.linalg.norm(u - w)'s sum, in its order (tested to the bit on numpy 1.26 and 2)
    dx, dy, dz = u[0] - w[0], u[1] - w[1], u[2] - w[2]
    return math.sqrt(dx * dx + dy * dy + dz * dz)


@njit(cache=True, inline="always")
def _hand(a, b, c):
    """np.sign of :func:`startrack.matching.geometry.triple_products`, in its order."""
    t = (a[0] * (b[1] * c[2] - b[2] * c[1]) + a[1] * (b[2] * c[0] - b[0] * c[2])
         + a[2] * (b[0] * c[1] - b[1] * c[0]))
    return np.sign(t)


@njit(cache=True)
def catalog_sides(tri_rows, vectors):
    """Side lengths (M x 3: |v0 - v1|, |v1 - v2|, |v0 - v2|) and handedness (M) of the
    catalog triangles ``tri_rows`` (M x 3 rows of ``vectors``) in their table order."""
    m = len(tri_rows)
    out = np.empty((m, 4))
    for r in range(m):
        _describe(vectors[tri_rows[r, 0]], vectors[tri_rows[r, 1]], vectors[tri_rows[r, 2]],
                  out[r])
    return out[:, :3], out[:, 3]


@njit(cache=True, inline="always")
def _describe(v0, v1, v2, out):
    """A triangle's sides |v0 - v1|, |v1 - v2|, |v0 - v2| and handedness into out[:4]."""
    out[0], out[1], out[2], out[3] = _dist(v0, v1), _dist(v1, v2), _dist(v0, v2), \
        _hand(v0, v1, v2)


@njit(cache=True)
def map_sides(obs_tri, sides, hand, side_tol, check_mirror):
    """:func:`map_vertices` on the catalog triangles' :func:`catalog_sides`."""
    o0, o1, o2 = obs_tri[0], obs_tri[1], obs_tri[2]
    obs_sides = (_dist(o0, o1), _dist(o1, o2), _dist(o0, o2))
    obs_hand = _hand(o0, o1, o2)
    m = len(sides)
    cand = np.empty(6 * m, np.int64)
    perm = np.empty(6 * m, np.int64)
    err = np.empty(6 * m)
    count = 0
    for k in range(6):
        p0, p1, p2 = PERMS[k, 0], PERMS[k, 1], PERMS[k, 2]
        s0, s1, s2 = _SIDE_OF_SUM[p0 + p1], _SIDE_OF_SUM[p1 + p2], _SIDE_OF_SUM[p0 + p2]
        sign = -1.0 if ODD[k] else 1.0
        for r in range(m):
            e = max(abs(sides[r, s0] - obs_sides[0]), abs(sides[r, s1] - obs_sides[1]),
                    abs(sides[r, s2] - obs_sides[2]))
            if not e <= side_tol:
                continue
            if check_mirror and hand[r] * sign != obs_hand:
                continue
            cand[count], perm[count], err[count] = r, k, e
            count += 1
    order = np.argsort(err[:count], kind="mergesort")
    return cand[order], perm[order]


@njit(cache=True)
def map_vertices(obs_tri, tri_rows, vectors, side_tol, check_mirror):
    """Vertex correspondences between one observed triangle (3 x 3) and catalog triangles
    (rows ``tri_rows`` (M x 3) of ``vectors``): for each of the six vertex orders whose
    sides all agree within ``side_tol`` (and, if ``check_mirror``, whose handedness
    agrees), the candidate index and the order (a row of :data:`PERMS`: observed vertex
    v is catalog vertex PERMS[order, v]). Returns (candidate, order) arrays, best side
    agreement first (ties: by order, then candidate)."""
    sides, hand = catalog_sides(tri_rows, vectors)
    return map_sides(obs_tri, sides, hand, side_tol, check_mirror)


def frame_tuple(vectors: np.ndarray, triples: np.ndarray, tolerance_sigma: float,
                side_tol: float, sigma: float) -> tuple:
    """The per-frame arguments of the lookups: the observed vectors (n x 3); each sorted
    triple's (area, polar, sigma_area, sigma_polar) (T x 4, rows as ``triples``, NaN
    until a lookup needs them) and the row of each triple code (a * n + b) * n + c; the
    window half-width in sigmas; the side tolerance of the vertex mapping; the per-axis
    centroid sigma the feature sigmas are propagated from."""
    n = len(vectors)
    lut = np.full(n ** 3, -1, np.int64)
    lut[(triples[:, 0] * n + triples[:, 1]) * n + triples[:, 2]] = np.arange(len(triples))
    return (np.ascontiguousarray(vectors, dtype=np.float64),
            np.full((len(triples), 4), np.nan), lut, float(tolerance_sigma),
            float(side_tol), float(sigma))


def frame_memo(n: int, buffers: tuple[np.ndarray, ...] | None = None,
               rows: int = 1 << 12) -> tuple[np.ndarray, ...]:
    """Per-frame memo of the lookups: (kept_info, kept, info, store, scratch). For each
    sorted triple code, kept_info holds (start, length, area window size) in ``kept``
    (start -1 until looked up), whose rows are (catalog rows x 3, sides x 3, handedness)
    of the triangles the polar filter kept; for each ordered triple code, info holds
    (start, length) in ``store``, the mapped catalog rows (K x 3); ``scratch`` holds the
    polar filter's picks from one area window. ``buffers`` (kept, store, scratch) are
    an earlier frame's (:func:`memo_buffers`), reused: fresh memory costs a page fault
    per 4 kB touched, more than the lookups themselves on a junk frame."""
    if buffers is None:
        buffers = (np.empty((rows, 7)), np.empty((rows, 3), np.int64),
                   np.empty(4 * rows, np.int64))
    kept, store, scratch = buffers
    return (np.full((n ** 3, 3), -1, np.int64), kept, np.full((n ** 3, 2), -1, np.int64),
            store, scratch)


def memo_buffers(memo: tuple[np.ndarray, ...]) -> tuple[np.ndarray, ...]:
    """The reusable buffers of a memo (as grown): for :func:`frame_memo`."""
    return memo[1], memo[3], memo[4]


@njit(cache=True)
def _grown(arr, fill, need):
    if fill + need <= len(arr):
        return arr
    grown = np.empty((max(2 * len(arr), fill + need), arr.shape[1]), arr.dtype)
    grown[:fill] = arr[:fill]
    return grown


@njit(cache=True)
def _kept(code, frame, table, memo, state):
    """The polar-kept triangles of sorted triple ``code`` (rows of ``memo[1]``), found
    the first time they are asked for: (start, length, area window size, memo)."""
    vec, feats, lut, k = frame[0], frame[1], frame[2], frame[3]
    area_v, kk, km, kq, polar_v, rows, cat = table
    kept_info, kept, info, store, scratch = memo
    if kept_info[code, 0] < 0:
        n = vec.shape[0]
        f = feats[lut[code]]
        f[0], f[1], f[2], f[3] = features(vec[code // (n * n)], vec[code // n % n],
                                          vec[code % n], frame[5])
        start, stop = kvector_range(area_v, kk, km, kq, f[0] - k * f[2], f[0] + k * f[2])
        p_lo, p_hi = f[1] - k * f[3], f[1] + k * f[3]
        # Reused across windows: a fresh window-sized array is a page fault per 4 kB.
        if stop - start > len(scratch):
            scratch = np.empty(2 * (stop - start), np.int64)
        m = 0
        for e in range(start, stop):
            scratch[m] = e  # branch-free: the filter keeps a few percent, unpredictably
            m += (polar_v[e] >= p_lo) & (polar_v[e] <= p_hi)
        fill = state[KEPT_FILL]
        kept = _grown(kept, fill, m)
        for r in range(m):
            i, j, l = rows[scratch[r], 0], rows[scratch[r], 1], rows[scratch[r], 2]
            out = kept[fill + r]
            out[0], out[1], out[2] = i, j, l
            _describe(cat[i], cat[j], cat[l], out[3:7])
        kept_info[code, 0], kept_info[code, 1], kept_info[code, 2] = fill, m, stop - start
        state[KEPT_FILL] = fill + m
    return kept_info[code, 0], kept_info[code, 1], kept_info[code, 2], (
        kept_info, kept, info, store, scratch)


@njit(cache=True)
def lookup(a, b, c, frame, table, memo, state):
    """The catalog triangles of the observed triple (a, b, c) as rows of catalog stars in
    its vertex order, best side agreement first; worked out (and counted) once per frame
    and vertex order. Returns (rows, memo): the memo's arrays may have grown."""
    vec, k, side_tol = frame[0], frame[3], frame[4]
    n = vec.shape[0]
    code = (a * n + b) * n + c
    if memo[2][code, 0] < 0:
        lo, hi = min(a, b, c), max(a, b, c)
        sorted_code = (lo * n + (a + b + c - lo - hi)) * n + hi
        s0, m, n_area, memo = _kept(sorted_code, frame, table, memo, state)
        kept_info, kept, info, store, scratch = memo
        obs = np.empty((3, 3))
        obs[0], obs[1], obs[2] = vec[a], vec[b], vec[c]
        f = frame[1][frame[2][sorted_code]]  # the mirror is refused unless too flat to tell
        cand, perm = map_sides(obs, kept[s0:s0 + m, 3:6], kept[s0:s0 + m, 6], side_tol,
                               f[0] > k * f[2])
        fill = state[STORE_FILL]
        store = _grown(store, fill, len(cand))
        for r in range(len(cand)):
            for v in range(3):
                store[fill + r, v] = int(kept[s0 + cand[r], PERMS[perm[r], v]])
        info[code, 0], info[code, 1] = fill, len(cand)
        state[STORE_FILL] = fill + len(cand)
        state[CANDIDATES] += n_area
        state[POLAR_KEPT] += m
        state[LOOKUPS] += 1
        memo = (kept_info, kept, info, store, scratch)
    info, store = memo[2], memo[3]
    return store[info[code, 0]:info[code, 0] + info[code, 1]], memo
