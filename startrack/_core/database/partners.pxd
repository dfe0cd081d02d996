# Windowed partner search on a pair table's neighbour lists: a catalog star's partners
# in the pairs where it is the first star (the "lo" run) or the second (the "hi" run),
# each run in table order, so by angle, so that a window is two bisections away.

from startrack._core._sort cimport first_at_least


cdef inline Py_ssize_t run_partners(const long long[::1] start, const int[::1] nbr,
                                    const double[::1] ang, Py_ssize_t star, double lo,
                                    double hi, long long[::1] out,
                                    Py_ssize_t count) noexcept nogil:
    """Append the partners of ``star`` in one run whose pair angle lies in [lo, hi] to
    ``out`` from position ``count`` (at most len(out) written); return the new count,
    every partner counted."""
    cdef Py_ssize_t b = start[star + 1]
    cdef Py_ssize_t p = first_at_least(ang, start[star], b, lo)
    while p < b and ang[p] <= hi:
        if count < out.shape[0]:
            out[count] = nbr[p]
        count += 1
        p += 1
    return count
