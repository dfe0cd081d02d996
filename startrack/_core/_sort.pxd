# Sorted-range search shared by the database lookups and the cone and nearest queries.

from libc.math cimport ceil, floor


ctypedef fused sorted_value:
    double
    long long


cdef inline Py_ssize_t first_at_least(const sorted_value[::1] values, Py_ssize_t lo,
                                      Py_ssize_t hi, sorted_value x) noexcept nogil:
    """The first position in ascending ``values[lo:hi]`` whose value is >= ``x`` (``hi``
    if none)."""
    cdef Py_ssize_t mid
    while lo < hi:
        mid = (lo + hi) >> 1
        if values[mid] < x:
            lo = mid + 1
        else:
            hi = mid
    return lo


cdef struct Span:
    Py_ssize_t start
    Py_ssize_t stop


cdef inline Span kvector_range(const double[::1] values, const long long[::1] kk, double m,
                               double q, double lo, double hi) noexcept nogil:
    """Positions [start, stop) of the sorted ``values`` within [lo, hi], from the k-vector
    ``kk`` on the line m*i + q: two entries of ``kk``, then the slice trimmed at its ends
    (at most about one bin's worth of values on each side). An empty or NaN range is
    (0, 0)."""
    cdef Py_ssize_t n = values.shape[0]
    cdef Span span
    span.start = 0
    span.stop = 0
    if n == 0 or not hi >= lo:
        return span
    cdef Py_ssize_t jb = <Py_ssize_t>min(max(floor((lo - q) / m), 0.0), n - 1.0)
    cdef Py_ssize_t jt = <Py_ssize_t>min(max(ceil((hi - q) / m), 0.0), n - 1.0)
    # kk[jb] values lie at or below z(jb) <= lo, so the answer starts at or after it;
    # kk[jt] values lie at or below z(jt) >= hi, so it ends at or before it.
    cdef Py_ssize_t start = kk[jb], stop = kk[jt]
    while start > 0 and values[start - 1] >= lo:
        start -= 1
    while start < n and values[start] < lo:  # not bounded by stop: it may still be short
        start += 1
    while stop < n and values[stop] <= hi:
        stop += 1
    while stop > start and values[stop - 1] > hi:
        stop -= 1
    span.start = start
    span.stop = stop
    return span


cdef inline Py_ssize_t first_above(const double[::1] values, Py_ssize_t lo, Py_ssize_t hi,
                                   double x) noexcept nogil:
    """The first position in ascending ``values[lo:hi]`` whose value is > ``x`` (``hi`` if
    none): numpy's ``searchsorted(side="right")``, where first_at_least is "left"."""
    cdef Py_ssize_t mid
    while lo < hi:
        mid = (lo + hi) >> 1
        if values[mid] <= x:
            lo = mid + 1
        else:
            hi = mid
    return lo
