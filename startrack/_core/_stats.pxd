# Order statistics with numpy's semantics (NaN in, NaN out), for the kernels that fit a
# scatter to a frame's few hundred values.

from libc.math cimport NAN, isnan


cdef inline void _select(double[::1] v, Py_ssize_t k) noexcept nogil:
    """Reorder ``v`` so that v[k] is the value a full sort would put there, with nothing
    greater before it and nothing smaller after it (Hoare's selection, O(n))."""
    cdef Py_ssize_t lo = 0, hi = v.shape[0] - 1, i, j
    cdef double pivot, t
    while lo < hi:
        pivot = v[(lo + hi) >> 1]
        i, j = lo, hi
        while i <= j:
            while v[i] < pivot:
                i += 1
            while v[j] > pivot:
                j -= 1
            if i <= j:
                t = v[i]
                v[i] = v[j]
                v[j] = t
                i += 1
                j -= 1
        if k <= j:
            hi = j
        elif k >= i:
            lo = i
        else:
            return


cdef inline double median_inplace(double[::1] v) noexcept nogil:
    """numpy's median of ``v``, which it reorders: NaN for no value or any NaN, the middle
    two averaged. By selection, not a full sort: the same order statistics, in O(n)."""
    cdef Py_ssize_t n = v.shape[0], e
    if n == 0:
        return NAN
    for e in range(n):
        if isnan(v[e]):
            return NAN
    _select(v, n // 2)
    cdef double upper = v[n // 2], lower
    if n % 2:
        return upper
    lower = v[0]
    for e in range(1, n // 2):
        if v[e] > lower:
            lower = v[e]
    return (lower + upper) / 2.0


cdef inline double ptp(const double[::1] v) noexcept nogil:
    """numpy's ptp of a non-empty array (max - min): NaN if any value is NaN."""
    cdef double lo = v[0], hi = v[0]
    cdef Py_ssize_t e
    for e in range(v.shape[0]):
        if isnan(v[e]):
            return NAN
        if v[e] < lo:
            lo = v[e]
        if v[e] > hi:
            hi = v[e]
    return hi - lo
