"""The hybrid matcher's search (Sedaghat, Toloei and Ghanbarpoor, 2011), compiled: the
angle votes that shortlist catalog stars, each observed pair's catalog pairs among them,
the catalog triangles joined from two of those whose planar area and polar moment match
the observed triangle's, and the fourth observed star that confirms one. A search
returns at each confirmed (or, without the fourth star, each found) triangle, so that
verification's first acceptance ends it."""

import numpy as np

from libc.math cimport hypot

from startrack._core.database.pair_tables cimport PairNeighbours, partners
from startrack._core._stable cimport merge_sort
from startrack._core._triangle cimport Features, Shape, features, shape, triple_product

include "hybrid_lists.pxi"


def triple_features(vectors, triples, double sigma):
    """(area, polar, sigma_area, sigma_polar) of each observed triple (rows of
    ``triples``), as startrack.database._triangles.feature_sigmas gives them."""
    cdef const double[:, ::1] v = np.ascontiguousarray(vectors, dtype=np.float64)
    cdef const long long[:, ::1] tri = np.ascontiguousarray(triples, dtype=np.int64)
    out_arr = np.empty((tri.shape[0], 4))
    cdef double[:, ::1] out = out_arr
    cdef Features f
    cdef Py_ssize_t t
    for t in range(tri.shape[0]):
        f = features(&v[tri[t, 0], 0], &v[tri[t, 1], 0], &v[tri[t, 2], 0], sigma)
        out[t, 0], out[t, 1], out[t, 2], out[t, 3] = f.area, f.polar, f.sigma_area, \
            f.sigma_polar
    return out_arr


cdef class HybridFrame:
    """One frame's constants for the hybrid search: the observed ``triples`` (T x 3) in
    search order with their ``feats`` (T x 4, :func:`triple_features`) and the
    handedness each catalog triangle must have (``hands``, 0: too flat to tell); the
    observed angles ``ang`` (n x n) and the angle tolerance ``tol``; the feature windows'
    half-width ``tolerance_sigma`` in sigmas."""

    cdef const long long[:, ::1] triples
    cdef const double[:, ::1] feats, ang
    cdef const long long[::1] hands
    cdef double tol, k

    def __init__(self, triples, feats, hands, ang, double tol, double tolerance_sigma):
        self.triples = np.ascontiguousarray(triples, dtype=np.int64)
        self.feats = np.ascontiguousarray(feats, dtype=np.float64)
        self.hands = np.ascontiguousarray(hands, dtype=np.int64)
        self.ang = np.ascontiguousarray(ang, dtype=np.float64)
        self.tol, self.k = tol, tolerance_sigma


cdef inline int _isign(double x) noexcept nogil:
    return (x > 0) - (x < 0)


cdef double _feature_test(const double[:, ::1] cat, long long x, long long y, long long z,
                          const double* f, double k, long long hand) except? -2.0:
    """Error in sigmas of the catalog triangle (x, y, z) against the features ``f``; -1
    when its area, polar moment or (unless ``hand`` is 0) handedness does not match."""
    cdef Shape s = shape(&cat[x, 0], &cat[y, 0], &cat[z, 0])
    if abs(s.area - f[0]) > k * f[2] or abs(s.polar - f[1]) > k * f[3]:
        return -1.0
    if hand != 0 and _isign(triple_product(&cat[x, 0], &cat[y, 0], &cat[z, 0])) != hand:
        return -1.0
    return hypot((s.area - f[0]) / f[2], (s.polar - f[1]) / f[3])


cdef Py_ssize_t _keep_best(long long[:, ::1] best_rows, double[::1] best_err,
                           Py_ssize_t count, const long long[::1] abc,
                           const long long[::1] trip, double e) noexcept nogil:
    """Insert triangle ``trip`` of triple ``abc`` with error ``e`` into the best so far
    (ascending error, ties in arrival order: a stable sort's), at most len(best_err) of
    them; return how many are kept."""
    cdef Py_ssize_t cap = best_err.shape[0], i = min(count, cap), j, c
    while i > 0 and best_err[i - 1] > e:
        i -= 1
    if i >= cap:
        return count
    j = min(count, cap - 1)
    while j > i:
        for c in range(6):
            best_rows[j, c] = best_rows[j - 1, c]
        best_err[j] = best_err[j - 1]
        j -= 1
    for c in range(3):
        best_rows[i, c], best_rows[i, 3 + c] = abc[c], trip[c]
    best_err[i] = e
    return min(count + 1, cap)


def keep_best(best_rows, best_err, Py_ssize_t count, abc, trip, double e):
    """:func:`_keep_best` on arrays (best_rows K x 6 as (a, b, c, x, y, z))."""
    return _keep_best(best_rows, best_err, count, np.ascontiguousarray(abc, dtype=np.int64),
                      np.ascontiguousarray(trip, dtype=np.int64), e)


include "hybrid_search.pxi"
