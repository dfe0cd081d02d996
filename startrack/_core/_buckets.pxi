# The bucket sort behind the database builds (included by builds.pyx and close_pairs.pyx):
# values counted into buckets of about PER_BUCKET each, then each bucket sorted in place,
# stably. The including module cimports merge_sort from startrack._core._stable.

cdef Py_ssize_t PER_BUCKET = 8  # values per bucket on average
cdef Py_ssize_t CROWDED = 32  # more in one bucket: merge sort, as insertion sort is quadratic


cdef inline Py_ssize_t _bucket(double value, double lo, double scale,
                               Py_ssize_t nb) noexcept nogil:
    return min(<Py_ssize_t>((value - lo) * scale), nb - 1)


cdef int _sort_buckets(const long long[::1] start, long long[::1] rows,
                       double[::1] key) noexcept nogil:
    """Each bucket ``start[b]:start[b + 1]`` sorted by ``key``, ``rows`` alongside, stably:
    insertion sort (a strict comparison keeps equal keys in order), or a merge sort for a
    crowded bucket, as insertion sort is quadratic. -1 when that merge finds no memory."""
    return _sort_bucket_range(start, rows, key, 0, start.shape[0] - 1)


cdef int _sort_bucket_range(const long long[::1] start, long long[::1] rows, double[::1] key,
                            Py_ssize_t first, Py_ssize_t stop) noexcept nogil:
    """:func:`_sort_buckets` on the buckets ``first`` to ``stop - 1`` alone."""
    cdef Py_ssize_t b, p, q
    cdef long long r
    cdef double k
    for b in range(first, stop):
        if start[b + 1] - start[b] > CROWDED:
            if merge_sort(&rows[0], &key[0], start[b], start[b + 1]) < 0:
                return -1
            continue
        for p in range(start[b] + 1, start[b + 1]):
            r, k = rows[p], key[p]
            q = p - 1
            while q >= start[b] and key[q] > k:
                rows[q + 1], key[q + 1] = rows[q], key[q]
                q -= 1
            rows[q + 1], key[q + 1] = r, k
    return 0
