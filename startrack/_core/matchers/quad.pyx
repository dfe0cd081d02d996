"""Scale-free four-star pattern search of one focal-length window (the ``quad`` matcher)
in one call: each image pattern's 32 neighbouring keys looked up in a level's sorted key
table through a bucket index, the first ratio test, the best of the 24 star orders, and
the candidates ranked by edge agreement (see :mod:`startrack.matchers._quad`)."""

import numpy as np

cimport cython
from libc.math cimport INFINITY, M_PI, asin, fabs, isfinite, sin, sqrt

from startrack._core._stable cimport merge_sort
from startrack._core.matchers.quad_confirm cimport Confirmer


cdef class QuadTable:
    """One level's pattern table (sorted keys, quads, uint8 ratios) with a bucket index
    on a key's three highest ratio digits: ``bucket[b]`` is the first row whose key is at
    least ``b * nbins**2``, so a key's rows are found by a short scan of its bucket."""
    cdef const int[::1] keys
    cdef const int[:, ::1] quads
    cdef const unsigned char[:, ::1] ratios
    cdef const int[::1] bucket

    def __init__(self, keys, quads, ratios, long long nbins):
        keys = np.ascontiguousarray(keys, np.int32)  # nbins**5 < 2**31
        self.keys = keys
        self.quads = np.ascontiguousarray(quads, np.int32)
        self.ratios = np.ascontiguousarray(ratios, np.uint8)
        top = int(keys[len(keys) - 1]) // nbins ** 2 + 1 if len(keys) else 0
        starts = np.arange(top + 1, dtype=np.int64) * nbins ** 2
        self.bucket = np.searchsorted(keys, starts).astype(np.int32)


cdef class QuadRules:
    """The matcher's constants: the ratio tolerance of a key lookup and of the edge test,
    the key quantisation, the first test's bound on the stored ratios, the candidate cap,
    the image stars that make patterns (at most 64) and the nearest stars a sparse one
    reaches, the six edges of a pattern, and for each of the 24 star orders its star order
    (``perms``) and the catalog edge that each image edge corresponds to (``perm_edges``)."""
    cdef double tolerance, bin, near, ratio_unit
    cdef long long nbins, max_candidates, image_stars, image_nearest
    cdef const long long[:, ::1] edges
    cdef const long long[:, ::1] perms
    cdef const long long[:, ::1] perm_edges

    def __init__(self, *, double tolerance, double bin, long long nbins, double near,
                 double ratio_unit, long long max_candidates, long long image_stars,
                 long long image_nearest, edges, perms, perm_edges):
        if not 0 < image_stars <= 64:
            raise ValueError(f"image_stars {image_stars}: must be in 1..64")
        if not bin > 0:
            raise ValueError(f"bin {bin}: must be positive")
        self.image_stars, self.image_nearest = image_stars, image_nearest
        self.tolerance, self.bin, self.nbins = tolerance, bin, nbins
        self.near, self.ratio_unit, self.max_candidates = near, ratio_unit, max_candidates
        self.edges = np.ascontiguousarray(edges, np.int64)
        self.perms = np.ascontiguousarray(perms, np.int64)
        self.perm_edges = np.ascontiguousarray(perm_edges, np.int64)


cdef class QuadMatches:
    """Observed and catalog patterns that agree, best first: observation rows (K x 4),
    catalog rows in matching order (K x 4), scale (observed / catalog size) and the
    largest edge-ratio disagreement."""
    cdef readonly object obs
    cdef readonly object cat
    cdef readonly object scale
    cdef readonly object error


cdef class _Ints:
    """A growing int64 array."""
    cdef long long[::1] a
    cdef Py_ssize_t n

    def __cinit__(self):
        self.a = np.empty(256, np.int64)
        self.n = 0

    cdef inline void push(self, long long v):
        cdef long long[::1] b
        if self.n == self.a.shape[0]:
            b = np.empty(2 * self.n, np.int64)
            b[:self.n] = self.a[:self.n]
            self.a = b
        self.a[self.n] = v
        self.n += 1


include "quad_lookup.pxi"


cdef void _pairs(QuadTable t, QuadRules rules, const double[:, ::1] edges, _Ints pat,
                 _Ints row):
    """Every (image pattern, table row) that passes the first test, once, by pattern then
    row."""
    cdef _Ints rows = _Ints()
    cdef double r[5]
    cdef long long lo[5]
    cdef long long hi[5]
    cdef Py_ssize_t m, k
    for m in range(edges.shape[0]):
        _key_ranges(rules, &edges[m, 0], r, lo, hi)
        rows.n = 0
        _near_rows(t, rules, r, lo, hi, rows)
        for k in range(rows.n):
            pat.push(m)
            row.push(rows.a[k])


cdef object _table_rows(QuadTable t, _Ints row):
    """The catalog rows (P x 4) of the paired table rows."""
    out = np.empty((row.n, 4), np.int64)
    cdef long long[:, ::1] q = out
    cdef Py_ssize_t p
    cdef int k
    for p in range(row.n):
        for k in range(4):
            q[p, k] = t.quads[row.a[p], k]
    return out


cdef Py_ssize_t _best_orders(QuadRules rules, const double[:, ::1] edges, _Ints pat,
                             const double[:, ::1] cat_edges, long long[::1] best,
                             long long[::1] good, double[::1] error) noexcept:
    """Each pair's best star order (``best``) and the pairs whose largest edge-ratio
    disagreement is within the tolerance (``good``, with that disagreement in ``error``);
    returns how many are good."""
    cdef double least
    cdef Py_ssize_t p, n = 0
    for p in range(pat.n):
        least = _best_order(rules, &edges[pat.a[p], 0], &cat_edges[p, 0], &best[p])
        if least <= rules.tolerance:
            good[n], error[n] = p, least
            n += 1
    return n


cdef double _best_order(QuadRules rules, const double *edges, const double *cat_edges,
                        long long *best) noexcept:
    """The best of the 24 star orders of an image pattern (its six ``edges``) against a
    catalog pattern's (written to ``best``) and its largest edge-ratio disagreement."""
    cdef double img[6]
    cdef double c[6]
    cdef double largest = edges[0], cmax = cat_edges[0], worst, least = 0.0, d
    cdef int k, o
    for k in range(1, 6):
        largest = max(largest, edges[k])
        cmax = max(cmax, cat_edges[k])
    for k in range(6):
        img[k] = edges[k] / largest
        c[k] = cat_edges[k] / cmax
    for o in range(24):
        worst = 0.0
        for k in range(6):
            d = fabs(img[k] - c[rules.perm_edges[o, k]])
            if d > worst:
                worst = d
        if o == 0 or worst < least:
            least, best[0] = worst, o
    return least


cdef inline double _scale(QuadRules rules, const double *edges, const double *cat_edges,
                          long long o) noexcept:
    """Observed over catalog pattern size (sums of the six edges, in matching order)."""
    cdef double num = 0.0, den = 0.0
    cdef int k
    for k in range(6):
        num += edges[k]
        den += cat_edges[rules.perm_edges[o, k]]
    return num / den


cdef QuadMatches _ranked(QuadTable t, QuadRules rules, const long long[:, ::1] quads,
                         const double[:, ::1] edges, _Ints pat, _Ints row,
                         const double[:, ::1] cat_edges, const long long[::1] best,
                         const long long[::1] good, const double[::1] good_error,
                         Py_ssize_t n):
    """The first ``n`` of ``good`` as :class:`QuadMatches`, with catalog rows in the
    matching order and the scale of each pattern."""
    res = QuadMatches()
    res.obs, res.cat = np.empty((n, 4), np.int64), np.empty((n, 4), np.int64)
    res.scale, res.error = np.empty(n), np.empty(n)
    cdef long long[:, ::1] obs = res.obs
    cdef long long[:, ::1] cat = res.cat
    cdef double[::1] scale = res.scale
    cdef double[::1] error = res.error
    cdef Py_ssize_t g, p, o
    cdef int k
    for g in range(n):
        p = good[g]
        o = best[p]
        error[g] = good_error[g]
        scale[g] = _scale(rules, &edges[pat.a[p], 0], &cat_edges[p, 0], o)
        for k in range(4):
            obs[g, k] = quads[pat.a[p], k]
            cat[g, k] = t.quads[row.a[p], rules.perms[o, k]]
    return res


def match_window(QuadTable table, QuadRules rules, const double[:, ::1] cat,
                 const double[:, ::1] vectors, double max_edge, double sparse_edge):
    """The image's patterns (:func:`image_quads` of its unit ``vectors``) matched against
    ``table`` (rows of the catalog vectors ``cat``): the :class:`QuadMatches` best first
    (smallest disagreement, then image pattern, then table row), at most the rules'
    ``max_candidates``."""
    quads, edges = image_quads(rules, vectors, max_edge, sparse_edge)
    cdef _Ints pat = _Ints(), row = _Ints()
    if quads.shape[0] and table.keys.shape[0]:
        _pairs(table, rules, edges, pat, row)
    cat_edges = _edges(rules, cat, _table_rows(table, row))
    cdef long long[::1] best = np.empty(pat.n, np.int64)
    cdef long long[::1] good = np.empty(pat.n, np.int64)
    cdef double[::1] error = np.empty(pat.n)
    cdef Py_ssize_t n = _best_orders(rules, edges, pat, cat_edges, best, good, error)
    if n and merge_sort(&good[0], &error[0], 0, n) < 0:
        raise MemoryError("quad search: no scratch for sorting the candidates")
    return _ranked(table, rules, quads, edges, pat, row, cat_edges, best, good, error,
                   min(n, rules.max_candidates))


include "quad_patterns.pxi"
include "quad_first.pxi"
