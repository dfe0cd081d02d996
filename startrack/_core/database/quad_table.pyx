"""The 4-star pattern table's enumeration (startrack.database._quads): every pattern of a
star and its higher neighbours whose edges all fit the star's size limit."""

import numpy as np


cdef inline double _dot(const double[:, ::1] v, Py_ssize_t a, Py_ssize_t b) noexcept nogil:
    return v[a, 0] * v[b, 0] + v[a, 1] * v[b, 1] + v[a, 2] * v[b, 2]


def enumerate_quads(const long long[::1] indptr, const long long[::1] indices,
                    const double[:, ::1] vectors, const double[::1] cos_max,
                    const long long[::1] max_higher):
    """Every pattern (a, b, c, d), a < b < c < d, with b, c, d among the first
    ``max_higher[a]`` higher neighbours of a (CSR lists ``indptr``, ``indices``) and every
    edge within the angle whose cosine is ``cos_max[a]``: an (M, 4) int64 array, by a,
    then by neighbour order."""
    cdef Py_ssize_t m = _walk(indptr, indices, vectors, cos_max, max_higher, None)
    out = np.zeros((m, 4), np.int64)
    _walk(indptr, indices, vectors, cos_max, max_higher, out)
    return out


cdef Py_ssize_t _walk(const long long[::1] indptr, const long long[::1] indices,
                      const double[:, ::1] v, const double[::1] cos_max,
                      const long long[::1] max_higher, long long[:, ::1] out):
    """Count the patterns; write them to ``out`` too when it is given."""
    cdef Py_ssize_t m = 0, a, i, j, k, lo, hi, b, c, d
    cdef double cm
    cdef bint write = out is not None
    for a in range(indptr.shape[0] - 1):
        lo = indptr[a]
        hi = min(indptr[a + 1], indptr[a] + max_higher[a])
        cm = cos_max[a]
        for i in range(lo, hi):
            b = indices[i]
            for j in range(i + 1, hi):
                c = indices[j]
                if _dot(v, b, c) < cm:
                    continue
                for k in range(j + 1, hi):
                    d = indices[k]
                    if _dot(v, b, d) < cm or _dot(v, c, d) < cm:
                        continue
                    if write:
                        out[m, 0], out[m, 1], out[m, 2], out[m, 3] = a, b, c, d
                    m += 1
    return m
