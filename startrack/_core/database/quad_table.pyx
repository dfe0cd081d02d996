"""The 4-star pattern table's build kernels (startrack.database._quads): every pattern of a
star and its higher neighbours whose edges all fit the star's size limit, and each
pattern's key and stored ratios."""

from libc.math cimport asin, nearbyint, sqrt

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


def pattern_keys(const double[:, ::1] vectors, const long long[:, ::1] quads,
                 const long long[:, ::1] edges, double bin, long long nbins,
                 double ratio_steps):
    """Each pattern's key and stored ratios, the table's two columns that the patterns'
    geometry gives: its six edge angles (``edges``: the star pairs), sorted, the five
    smaller divided by the largest, quantised in ``bin`` steps into one int32 key
    (digit k weighs ``nbins**k``) and rounded to ``ratio_steps`` as uint8. The same
    arithmetic as numpy's in startrack.database._quads (chord, then 2 asin(chord / 2)),
    one pattern at a time: the numpy version held ~900 bytes a pattern in temporaries."""
    cdef Py_ssize_t m = quads.shape[0], q, e, s, t
    keys = np.empty(m, np.int32)
    ratios = np.empty((m, 5), np.uint8)
    cdef int[::1] k_out = keys
    cdef unsigned char[:, ::1] r_out = ratios
    cdef double ang[6]
    cdef double d0, d1, d2, chord, tmp, largest, r
    cdef long long key, digit, weight
    cdef Py_ssize_t a, b
    with nogil:
        for q in range(m):
            for e in range(6):
                a = quads[q, edges[e, 0]]
                b = quads[q, edges[e, 1]]
                d0 = vectors[a, 0] - vectors[b, 0]
                d1 = vectors[a, 1] - vectors[b, 1]
                d2 = vectors[a, 2] - vectors[b, 2]
                chord = sqrt(d0 * d0 + d1 * d1 + d2 * d2) / 2.0
                chord = 0.0 if chord < 0.0 else (1.0 if chord > 1.0 else chord)
                ang[e] = 2.0 * asin(chord)
            for s in range(1, 6):  # insertion sort of six
                tmp = ang[s]
                t = s - 1
                while t >= 0 and ang[t] > tmp:
                    ang[t + 1] = ang[t]
                    t -= 1
                ang[t + 1] = tmp
            largest = ang[5] if ang[5] > 0.0 else 1.0
            key = 0
            weight = 1
            for s in range(5):
                r = ang[s] / largest
                digit = <long long>(r / bin)
                digit = 0 if digit < 0 else (nbins - 1 if digit > nbins - 1 else digit)
                key += digit * weight
                weight *= nbins
                r_out[q, s] = <unsigned char>nearbyint(r * ratio_steps)
            k_out[q] = <int>key
    return keys, ratios
