# The camera as every compiled stage takes it: a pinhole (focal length, principal point,
# image size) with Brown-Conrady radial distortion, and the lens arithmetic on the
# normalised plane (u = (x - cx) / f). The one implementation of the model; the Python
# Camera and RadialDistortion call it through startrack._core.camera.optics.

cimport cython
from libc.math cimport hypot, sqrt
from libc.stdlib cimport free, malloc

#: Newton steps of the lens inversion at most (quadratic convergence: 12 is ample)
cdef enum:
    NEWTON_ITERATIONS = 12


cdef struct Lens:
    double k1
    double k2
    double k3
    double max_r2  # ideal r^2 up to which the model is invertible (inf: everywhere)
    double r_cap   # sqrt(max_r2): the largest ideal radius the inversion returns


cdef struct Geometry:
    # The camera of every compiled stage (verification's projection included).
    double f_px    # focal length, px
    double cx      # principal point, px
    double cy
    double width   # image size, px
    double height
    double k1      # the radial distortion (zeros: a pinhole)
    double k2
    double k3
    double max_r2  # ideal r^2 up to which the lens model is invertible (inf: everywhere)


cdef inline Lens lens_of(const Geometry* g) noexcept nogil:
    """The lens of a camera's geometry."""
    cdef Lens lens
    lens.k1, lens.k2, lens.k3, lens.max_r2 = g.k1, g.k2, g.k3, g.max_r2
    lens.r_cap = sqrt(g.max_r2)  # inf when the model never folds back
    return lens


cdef inline bint lens_is_identity(const Lens* lens) noexcept nogil:
    return lens.k1 == 0.0 and lens.k2 == 0.0 and lens.k3 == 0.0


cdef inline double lens_factor(const Lens* lens, double r2) noexcept nogil:
    """The radial scale ``1 + k1 r2 + k2 r2^2 + k3 r2^3`` (Horner, as numpy evaluates it)."""
    return 1.0 + r2 * (lens.k1 + r2 * (lens.k2 + r2 * lens.k3))


cdef inline double _clipped(double x, double cap) noexcept nogil:
    """np.clip(x, 0, cap): NaN stays NaN."""
    if x < 0.0:
        return 0.0
    if x > cap:
        return cap
    return x


@cython.cdivision(True)  # numpy's division: an inf or NaN, never an exception
cdef inline int lens_undistort(const Lens* lens, double* u, double* v, Py_ssize_t n,
                               Py_ssize_t stride) noexcept nogil:
    """Observed normalised coordinates made ideal, in place (``n`` of them, ``stride``
    doubles apart): Newton on the radius, every star stepped until no step exceeds 1e-15,
    each radius clipped to [0, r_cap]. -1 when out of memory."""
    cdef double* rd = <double*>malloc(2 * n * sizeof(double) + 1)
    if rd == NULL:
        return -1
    cdef double* r = rd + n
    cdef double r2, slope, step, scale
    cdef Py_ssize_t i
    cdef int it
    cdef bint moving
    for i in range(n):
        rd[i] = hypot(u[i * stride], v[i * stride])
        r[i] = rd[i] if rd[i] < lens.r_cap else lens.r_cap  # np.minimum: NaN stays
        if rd[i] != rd[i]:
            r[i] = rd[i]
    for it in range(NEWTON_ITERATIONS):
        moving = False
        for i in range(n):
            r2 = r[i] * r[i]
            slope = 1.0 + r2 * (3.0 * lens.k1 + r2 * (5.0 * lens.k2 + r2 * 7.0 * lens.k3))
            step = (r[i] * lens_factor(lens, r2) - rd[i]) / slope
            r[i] = _clipped(r[i] - step, lens.r_cap)
            if step > 1e-15 or step < -1e-15:
                moving = True
        if not moving:
            break
    for i in range(n):
        scale = r[i] / rd[i] if rd[i] > 0.0 else 1.0
        u[i * stride] = u[i * stride] * scale
        v[i * stride] = v[i * stride] * scale
    free(rd)
    return 0
