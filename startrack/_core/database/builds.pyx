"""The database builds' loops: the triangles of a pair graph with their canonical vertex
order, area and polar moment, the stable bucket argsort and gathers that put them in
order, and the k-vector's merge; each one pass over up to millions of entries (the close
pairs of a catalog: :mod:`startrack._core.sky.close_pairs`)."""

import numpy as np

from libc.stdlib cimport qsort

from startrack._core._stable cimport merge_sort
from startrack._core._triangle cimport Shape, chord, shape

include "_buckets.pxi"


def stable_argsort(const double[::1] values, double lo, double hi):
    """The stable ascending argsort of ``values`` (all in [lo, hi]) by a bucket sort:
    counting sort into about one bucket per 8 values, then insertion sort inside each (a
    stable merge sort for crowded ones), O(n) for spread-out values where a comparison
    sort of millions takes seconds.

    The keys travel with the indices, so each bucket is sorted in contiguous memory;
    fewer buckets than values keep the counts in cache while the values are scattered.
    """
    cdef Py_ssize_t n = values.shape[0], nb = max(n // PER_BUCKET, 1), e, b
    cdef double scale = nb / (hi - lo) if hi > lo else 0.0
    start_arr, order_arr = np.zeros(nb + 1, np.int64), np.empty(n, np.int64)
    key_arr = np.empty(n, np.float64)
    cdef long long[::1] start = start_arr, order = order_arr
    cdef double[::1] key = key_arr
    cdef long long[::1] fill
    with nogil:
        for e in range(n):
            start[_bucket(values[e], lo, scale, nb) + 1] += 1
        for b in range(nb):
            start[b + 1] += start[b]
    fill = start_arr[:nb].copy()
    with nogil:
        for e in range(n):  # the same bucket arithmetic as above, so the counts match
            b = _bucket(values[e], lo, scale, nb)
            order[fill[b]], key[fill[b]] = e, values[e]
            fill[b] += 1
        if _sort_buckets(start, order, key) < 0:
            with gil:
                raise MemoryError("stable_argsort: no memory for a bucket's merge")
    return order_arr


def take_triangles(const long long[::1] order, const long long[:, ::1] rows,
                   const double[::1] area, const double[::1] polar):
    """(rows, area, polar)[order], the rows as int32: the triangle table in area order."""
    cdef Py_ssize_t n = order.shape[0], p, e
    tr_arr = np.empty((n, 3), np.int32)
    ta_arr, tp_arr = np.empty(n, np.float64), np.empty(n, np.float64)
    cdef int[:, ::1] tr = tr_arr
    cdef double[::1] ta = ta_arr, tp = tp_arr
    with nogil:
        for p in range(n):
            e = order[p]
            tr[p, 0], tr[p, 1], tr[p, 2] = <int>rows[e, 0], <int>rows[e, 1], <int>rows[e, 2]
            ta[p], tp[p] = area[e], polar[e]
    return tr_arr, ta_arr, tp_arr


def is_sorted(const double[::1] values):
    """Whether ``values`` ascend (NaNs compare as np.diff(values) < 0 does: never)."""
    cdef Py_ssize_t e
    for e in range(1, values.shape[0]):
        if values[e] < values[e - 1]:
            return False
    return True


def count_at_most(const double[::1] values, double m, double q):
    """``np.searchsorted(values, m * np.arange(len(values)) + q, side="right")`` for
    ascending ``values`` and m > 0: one merge, where the binary searches cost
    O(n log n) cache misses, and no array of the n line points."""
    cdef Py_ssize_t n = values.shape[0], e, p = 0
    cdef double z
    k_arr = np.empty(n, np.int64)
    cdef long long[::1] k = k_arr
    with nogil:
        for e in range(n):
            z = m * <double>e + q  # e is exact as a double (n < 2**53): numpy's z
            while p < n and values[p] <= z:
                p += 1
            k[e] = p
    return k_arr


cdef int _compare_ids(const void* a, const void* b) noexcept nogil:
    cdef long long x = (<const long long*>a)[0], y = (<const long long*>b)[0]
    return (x > y) - (x < y)


def _forward_lists(Py_ssize_t n, const long long[::1] lo, const long long[::1] hi):
    """CSR of the forward neighbours k > i of each star, ascending: (start, nbr)."""
    start_arr, nbr_arr = np.zeros(n + 1, np.int64), np.empty(lo.shape[0], np.int64)
    cdef long long[::1] start = start_arr, nbr = nbr_arr
    cdef Py_ssize_t e, s
    for e in range(lo.shape[0]):
        start[lo[e] + 1] += 1
    for s in range(n):
        start[s + 1] += start[s]
    cdef long long[::1] fill = start_arr[:n].copy()
    for e in range(lo.shape[0]):
        nbr[fill[lo[e]]] = hi[e]
        fill[lo[e]] += 1
    for s in range(n):
        if start[s + 1] > start[s]:
            qsort(&nbr[start[s]], start[s + 1] - start[s], sizeof(long long), _compare_ids)
    return start_arr, nbr_arr


cdef inline void _canonical(const double[:, ::1] v, long long i, long long j, long long k,
                            long long[:, ::1] rows, Py_ssize_t t) noexcept nogil:
    """Row t of the table: (i, j, k) reordered so that vertex 0 faces the shortest side
    and vertex 2 the longest (np.argmin, np.argmax: first of equals)."""
    cdef double opp[3]
    cdef long long verts[3]
    verts[0], verts[1], verts[2] = i, j, k
    opp[0], opp[1], opp[2] = chord(&v[j, 0], &v[k, 0]), chord(&v[i, 0], &v[k, 0]), \
        chord(&v[i, 0], &v[j, 0])
    cdef int first = 0, last = 0, s
    for s in range(1, 3):
        if opp[s] < opp[first]:
            first = s
        if opp[s] > opp[last]:
            last = s
    if last == first:  # three equal sides
        last = (first + 2) % 3
    rows[t, 0], rows[t, 1], rows[t, 2] = verts[first], verts[3 - first - last], verts[last]


def triangles_of_pairs(Py_ssize_t n, const long long[::1] lo, const long long[::1] hi,
                       const double[:, ::1] vectors):
    """Every (i, j, k), i < j < k, whose three pairs are all among the pairs (lo < hi), in
    lexicographic order, each reordered so that vertex 0 faces the shortest side and
    vertex 2 the longest. Returns (rows (M x 3), area, polar)."""
    start_arr, nbr_arr = _forward_lists(n, lo, hi)
    cdef const long long[::1] start = start_arr, nbr = nbr_arr
    mark_arr = np.zeros(n, np.uint8)
    cdef unsigned char[::1] mark = mark_arr
    # First pass: count, so that the output is allocated once.
    cdef Py_ssize_t count = _triangle_pass(start, nbr, mark, vectors, np.empty((0, 3), np.int64),
                                           np.empty(0), np.empty(0), False)
    rows_arr, area_arr, polar_arr = np.empty((count, 3), np.int64), np.empty(count), \
        np.empty(count)
    _triangle_pass(start, nbr, mark, vectors, rows_arr, area_arr, polar_arr, True)
    return rows_arr, area_arr, polar_arr


cdef Py_ssize_t _triangle_pass(const long long[::1] start, const long long[::1] nbr,
                               unsigned char[::1] mark, const double[:, ::1] v,
                               long long[:, ::1] rows, double[::1] area,
                               double[::1] polar, bint fill) noexcept nogil:
    """One pass over the triangles (i < j < k, each pair among the forward lists):
    counted, and with ``fill`` written into rows, area and polar. Returns the count."""
    cdef Py_ssize_t n = start.shape[0] - 1, i, p, q, t = 0
    cdef long long j, k
    cdef Shape s
    for i in range(n):
        for p in range(start[i], start[i + 1]):
            mark[nbr[p]] = 1
        for p in range(start[i], start[i + 1]):
            j = nbr[p]
            for q in range(start[j], start[j + 1]):
                k = nbr[q]
                if not mark[k]:
                    continue
                if fill:
                    _canonical(v, i, j, k, rows, t)
                    s = shape(&v[rows[t, 0], 0], &v[rows[t, 1], 0], &v[rows[t, 2], 0])
                    area[t], polar[t] = s.area, s.polar
                t += 1
        for p in range(start[i], start[i + 1]):
            mark[nbr[p]] = 0
    return t
