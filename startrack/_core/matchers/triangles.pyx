"""The triangle matcher's search (Cole and Crassidis, 2006), compiled: each observed
triple's catalog triangles (k-vector range on area, polar-moment filter, vertex mapping
by side lengths with the mirror refused), and the pivots that join them on shared stars.

Every number is computed as the numpy reference computes it (the same operations in the
same order, tested to the bit), so that the search proposes what the reference did. Per
frame, the area window, polar filter and catalog sides of a triple are worked out once
for all six vertex orders (the "kept" memo), the mapping once per vertex order (the
"store"); both grow as they fill. A search returns at each triple that leaves an answer,
so that verification's first acceptance ends it.
"""

import itertools

import numpy as np


from startrack._core._sort cimport Span, first_at_least, kvector_range
from startrack._core._stable cimport merge_sort
from startrack._core._triangle cimport Features, chord, sign, triple_product
from startrack._core._triangle cimport features as _features

#: The six vertex orders (observed vertex v is catalog vertex PERMS[order, v]); the odd
#: ones reverse the handedness.
PERMS = np.array(list(itertools.permutations(range(3))), np.int64)
cdef int[18] _PERMS = [0, 1, 2, 0, 2, 1, 1, 0, 2, 1, 2, 0, 2, 0, 1, 2, 1, 0]
cdef double[6] _HAND = [1.0, -1.0, -1.0, 1.0, 1.0, -1.0]
# The side between vertices i and j, by i + j: (0, 1) -> 0, (0, 2) -> 2, (1, 2) -> 1
# (sides are |v0 - v1|, |v1 - v2|, |v0 - v2|).
cdef int[4] _SIDE_OF_SUM = [-1, 0, 2, 1]
# Columns of a kept row: catalog rows 0-2, then what _describe writes.
cdef enum:
    SIDES = 3
    HAND = 6
    KEPT_COLUMNS = 7


def features(v1, v2, v3, double sigma):
    """(area, polar, sigma_area, sigma_polar) of one observed triple, the numbers of
    :func:`startrack.database._triangles.triangle_features` and ``feature_sigmas``."""
    cdef const double[::1] a = np.ascontiguousarray(v1, dtype=np.float64)
    cdef const double[::1] b = np.ascontiguousarray(v2, dtype=np.float64)
    cdef const double[::1] c = np.ascontiguousarray(v3, dtype=np.float64)
    cdef Features f = _features(&a[0], &b[0], &c[0], sigma)
    return f.area, f.polar, f.sigma_area, f.sigma_polar


cdef inline void _describe(const double* v0, const double* v1, const double* v2,
                           double* out) noexcept nogil:
    """A triangle's sides |v0 - v1|, |v1 - v2|, |v0 - v2| and handedness into out[:4]."""
    out[0], out[1], out[2] = chord(v0, v1), chord(v1, v2), chord(v0, v2)
    out[3] = sign(triple_product(v0, v1, v2))


cdef Py_ssize_t _map_sides(const double* o0, const double* o1, const double* o2,
                           const double[:, ::1] kept, Py_ssize_t s0, Py_ssize_t m,
                           double side_tol, bint check_mirror, long long[:, ::1] picks,
                           double[::1] err) except -1:
    """The vertex orders of the kept triangles ``kept[s0:s0 + m]`` whose sides all agree
    with the observed triangle's within ``side_tol`` (and, if ``check_mirror``, whose
    handedness agrees): candidate r and order k into rows 0 and 1 of ``picks``, and
    into its row 2 their ranks, best side agreement first (ties: by order, then
    candidate); ``err`` is scratch. Each holds at least 6 m. Returns how many."""
    cdef double obs[4]
    _describe(o0, o1, o2, obs)
    cdef Py_ssize_t count = 0, k, r
    cdef int s0k, s1k, s2k
    cdef double e, d
    for k in range(6):
        s0k = _SIDE_OF_SUM[_PERMS[3 * k] + _PERMS[3 * k + 1]]
        s1k = _SIDE_OF_SUM[_PERMS[3 * k + 1] + _PERMS[3 * k + 2]]
        s2k = _SIDE_OF_SUM[_PERMS[3 * k] + _PERMS[3 * k + 2]]
        for r in range(m):
            e = abs(kept[s0 + r, SIDES + s0k] - obs[0])
            d = abs(kept[s0 + r, SIDES + s1k] - obs[1])
            if d > e:
                e = d
            d = abs(kept[s0 + r, SIDES + s2k] - obs[2])
            if d > e:
                e = d
            if not e <= side_tol:
                continue
            if check_mirror and kept[s0 + r, HAND] * _HAND[k] != obs[3]:
                continue
            picks[0, count], picks[1, count], picks[2, count], err[count] = r, k, count, e
            count += 1
    if count and merge_sort(&picks[2, 0], &err[0], 0, count) < 0:
        raise MemoryError("triangle search: no memory to sort the vertex mapping")
    return count


def map_vertices(obs_tri, tri_rows, vectors, double side_tol, bint check_mirror):
    """Vertex correspondences between one observed triangle (3 x 3) and catalog triangles
    (rows ``tri_rows`` (M x 3) of ``vectors``): (candidate, order) arrays, order a row of
    :data:`PERMS`, best side agreement first (ties: by order, then candidate)."""
    cdef const double[:, ::1] obs = np.ascontiguousarray(obs_tri, dtype=np.float64)
    cdef const double[:, ::1] cat = np.ascontiguousarray(vectors, dtype=np.float64)
    cdef const long long[:, ::1] rows = np.ascontiguousarray(tri_rows, dtype=np.int64)
    cdef Py_ssize_t m = rows.shape[0], r
    cdef double[:, ::1] kept = np.zeros((m, KEPT_COLUMNS))
    for r in range(m):
        _describe(&cat[rows[r, 0], 0], &cat[rows[r, 1], 0], &cat[rows[r, 2], 0],
                  &kept[r, SIDES])
    picks = np.empty((3, 6 * m), np.int64)
    count = _map_sides(&obs[0, 0], &obs[1, 0], &obs[2, 0], kept, 0, m, side_tol,
                       check_mirror, picks, np.empty(6 * m))
    order = picks[2, :count]
    return picks[0, order], picks[1, order]


cdef inline bint _holds(const long long[:] row, Py_ssize_t w, long long x) noexcept nogil:
    cdef Py_ssize_t col
    for col in range(w):
        if row[col] == x:
            return True
    return False


cdef object _join_pivot(const long long[:, :] left, Py_ssize_t col_p, Py_ssize_t col_q,
                        const long long[:, :] right):
    """Each row of ``left`` once per row of ``right`` (K x 3) whose first two columns
    equal the row's columns (col_p, col_q), that right row's last column appended (right
    rows in their own order); a row whose new star is already in it goes."""
    cdef Py_ssize_t m = left.shape[0], w = left.shape[1], n_right = right.shape[0]
    if m == 0 or n_right == 0:
        return np.zeros((0, w + 1), np.int64)
    cdef long long base = 0, key, new
    cdef Py_ssize_t p, r, count = 0, col
    for r in range(m):
        for col in range(w):
            base = max(base, left[r, col])
    for p in range(n_right):
        base = max(base, right[p, 0], right[p, 1], right[p, 2])
    base += 1
    keys_arr, order_arr = np.empty(n_right, np.int64), np.arange(n_right, dtype=np.int64)
    cdef long long[::1] keys = keys_arr, order = order_arr
    for p in range(n_right):
        keys[p] = right[p, 0] * base + right[p, 1]
    if merge_sort(&order[0], &keys[0], 0, n_right) < 0:
        raise MemoryError("triangle search: no memory to sort a pivot's keys")
    out_arr = np.empty((max(m, 16), w + 1), np.int64)
    cdef long long[:, ::1] out = out_arr
    for r in range(m):
        key = left[r, col_p] * base + left[r, col_q]
        p = first_at_least(keys, 0, n_right, key)
        while p < n_right and keys[p] == key:
            new = right[order[p], 2]
            p += 1
            if _holds(left[r], w, new):
                continue
            if count == out.shape[0]:
                out_arr = np.concatenate((out_arr, np.empty_like(out_arr)))
                out = out_arr
            for col in range(w):
                out[count, col] = left[r, col]
            out[count, w] = new
            count += 1
    return out_arr[:count]


def join_pivot(left, Py_ssize_t col_p, Py_ssize_t col_q, right):
    """startrack.matchers._shared.pair_joins.join_sorted(left, (col_p, col_q), right), compiled."""
    return _join_pivot(np.ascontiguousarray(left, dtype=np.int64), col_p, col_q,
                       np.ascontiguousarray(right, dtype=np.int64))


include "triangle_search.pxi"
