# A stable sort of indices by key, for the database builds' crowded buckets and the
# searches' orderings: the order numpy's argsort(kind="stable") gives.

from libc.stdlib cimport free, malloc

ctypedef fused sort_key:
    double
    long long


cdef inline int merge_sort(long long* order, sort_key* key, Py_ssize_t a,
                           Py_ssize_t b) noexcept nogil:
    """Stable bottom-up merge sort of key[a:b], order[a:b] alongside (ties: left first).
    Returns -1 when its scratch cannot be allocated, 0 otherwise."""
    cdef Py_ssize_t n = b - a, width = 1, lo, mid, hi, i, j, t
    if n < 2:
        return 0
    cdef long long* tmp_o = <long long*>malloc(n * sizeof(long long))
    cdef sort_key* tmp_k = <sort_key*>malloc(n * sizeof(sort_key))
    if tmp_o == NULL or tmp_k == NULL:
        free(tmp_o)
        free(tmp_k)
        return -1
    while width < n:
        lo = a
        while lo < b:
            mid, hi = min(lo + width, b), min(lo + 2 * width, b)
            i, j = lo, mid
            for t in range(lo - a, hi - a):
                if j >= hi or (i < mid and key[i] <= key[j]):
                    tmp_o[t], tmp_k[t] = order[i], key[i]
                    i += 1
                else:
                    tmp_o[t], tmp_k[t] = order[j], key[j]
                    j += 1
            lo += 2 * width
        for t in range(n):
            order[a + t], key[a + t] = tmp_o[t], tmp_k[t]
        width *= 2
    free(tmp_o)
    free(tmp_k)
    return 0
