# The index and value tests of the fitted rounds on their arrays (included by
# fitted_rounds.pyx).


cdef bint _within(const long long[::1] index, Py_ssize_t size) noexcept:
    """Whether every index lies in [0, size)."""
    cdef Py_ssize_t i
    for i in range(index.shape[0]):
        if index[i] < 0 or index[i] >= size:
            return False
    return True


cdef bint _same(const long long[::1] a, const long long[::1] b) noexcept:
    """Whether two index arrays hold the same values (``_same_stars``)."""
    if a.shape[0] != b.shape[0]:
        return False
    cdef Py_ssize_t i
    for i in range(a.shape[0]):
        if a[i] != b[i]:
            return False
    return True


cdef double _largest(const double[::1] a):
    """``float(np.maximum.reduce(a))``: the largest value, NaN if any is."""
    cdef double top = a[0]
    cdef Py_ssize_t i
    for i in range(1, a.shape[0]):
        if a[i] != a[i] or a[i] > top:
            top = a[i]
        if top != top:
            break
    return top


@cython.cdivision(True)
cdef double _moved_px(double f_before, double k1_before, double f, double k1,
                      double corner_r) noexcept:
    """How far a fit moved the camera, in pixels at the distance ``corner_r`` from the
    principal point: the focal length's change in scale, and a k1's at that radius."""
    cdef double t = corner_r / f
    return corner_r * fabs(f / f_before - 1.0) + corner_r * t * t * fabs(k1 - k1_before)
