# The camera's joint least squares (included in fit.pyx): the attitude, the focal
# length and a fitted k1 moved together by Gauss-Newton steps on the pixel residuals.
#
# Alternating Wahba's attitude with the focal length's own least squares converges
# linearly, and slowly where the two trade off: stars clustered off the axis let a turn
# of the attitude stand in for a change of scale, and twelve alternations there left the
# focal length 0.7% short and the attitude 200 arcsec off with every identity right.
# Gauss-Newton on all the parameters at once converges in a few steps wherever the
# problem is well posed, so a fit to the same stars returns the same camera.

# The parameters: a small rotation of the camera frame (3), the focal length, k1.
DEF _MAX_PARAMS = 5


cdef struct _Normal:
    # J^T J and J^T e of the pixel residuals e at one point, and sum e^2
    double a[_MAX_PARAMS][_MAX_PARAMS]
    double b[_MAX_PARAMS]
    double cost


@cython.cdivision(True)
cdef inline void _tangent(const double[:, ::1] cat, const double[:, ::1] rot, Py_ssize_t i,
                          double* u, double* v) noexcept nogil:
    """Catalog direction ``i`` on the camera's tangent plane at attitude ``rot`` (camera
    to sky): the one projection the normal equations and the cost-only sum share."""
    cdef double c0 = cat[i, 0] * rot[0, 0] + cat[i, 1] * rot[1, 0] + cat[i, 2] * rot[2, 0]
    cdef double c1 = cat[i, 0] * rot[0, 1] + cat[i, 1] * rot[1, 1] + cat[i, 2] * rot[2, 1]
    cdef double c2 = cat[i, 0] * rot[0, 2] + cat[i, 1] * rot[1, 2] + cat[i, 2] * rot[2, 2]
    u[0], v[0] = c0 / c2, c1 / c2


cdef void _offsets(const Geometry* g, const double[::1] x, const double[::1] y,
                   double[::1] dx, double[::1] dy) noexcept nogil:
    """The pixels' offsets from the principal point, into ``dx``, ``dy``."""
    cdef Py_ssize_t i
    for i in range(x.shape[0]):
        dx[i], dy[i] = x[i] - g.cx, y[i] - g.cy


@cython.cdivision(True)
cdef void _normal_equations(const Lens* described, const double[:, ::1] cat,
                            const double[:, ::1] rot, const double[::1] dx,
                            const double[::1] dy, double f, double k1, int n_params,
                            _Normal* out) noexcept nogil:
    """The normal equations at attitude ``rot`` (camera to sky), focal length ``f`` and
    (without a described lens) the k1-only lens ``k1``; ``n_params`` 5 fits k1 too.
    The model: pixel offset = f L(u, v), (u, v) the catalog direction on the camera's
    tangent plane and L the lens; a rotation w of the camera frame moves a direction c
    to c x w."""
    cdef Py_ssize_t i
    cdef int p, q, k
    cdef double u, v, r2, s, ds, ex, ey, ru
    cdef double du[3]
    cdef double dv[3]
    cdef double jx[_MAX_PARAMS]
    cdef double jy[_MAX_PARAMS]
    cdef bint lens = not lens_is_identity(described)
    for p in range(_MAX_PARAMS):
        out.b[p] = 0.0
        for q in range(_MAX_PARAMS):
            out.a[p][q] = 0.0
    out.cost = 0.0
    for i in range(cat.shape[0]):
        _tangent(cat, rot, i, &u, &v)
        r2 = u * u + v * v
        if lens:  # the radial scale s(r^2) and its derivative
            s = lens_factor(described, r2)
            ds = described.k1 + r2 * (2.0 * described.k2 + 3.0 * described.k3 * r2)
        else:
            s, ds = 1.0 + k1 * r2, k1
        ex, ey = dx[i] - f * s * u, dy[i] - f * s * v
        out.cost += ex * ex + ey * ey
        du[0], du[1], du[2] = u * v, -(1.0 + u * u), v
        dv[0], dv[1], dv[2] = 1.0 + v * v, -u * v, -u
        for k in range(3):  # through the lens: s I + 2 s' (u, v)(u, v)^T
            ru = 2.0 * ds * (u * du[k] + v * dv[k])
            jx[k] = f * (s * du[k] + ru * u)
            jy[k] = f * (s * dv[k] + ru * v)
        jx[3], jy[3] = s * u, s * v
        if n_params == 5:
            jx[4], jy[4] = f * r2 * u, f * r2 * v
        for p in range(n_params):
            out.b[p] += jx[p] * ex + jy[p] * ey
            for q in range(p + 1):
                out.a[p][q] += jx[p] * jx[q] + jy[p] * jy[q]
    for p in range(n_params):
        for q in range(p):
            out.a[q][p] = out.a[p][q]


@cython.cdivision(True)
cdef double _cost(const Lens* described, const double[:, ::1] cat, const double[:, ::1] rot,
                  const double[::1] dx, const double[::1] dy, double f,
                  double k1) noexcept nogil:
    """The ``cost`` of :func:`_normal_equations` alone, by the same arithmetic in the same
    order (so the same to the last bit)."""
    cdef Py_ssize_t i
    cdef double u, v, r2, s, ex, ey, cost = 0.0
    cdef bint lens = not lens_is_identity(described)
    for i in range(cat.shape[0]):
        _tangent(cat, rot, i, &u, &v)
        r2 = u * u + v * v
        s = lens_factor(described, r2) if lens else 1.0 + k1 * r2
        ex, ey = dx[i] - f * s * u, dy[i] - f * s * v
        cost += ex * ex + ey * ey
    return cost


@cython.cdivision(True)
cdef bint _solve_normal(_Normal* n, int n_params, double* step) noexcept nogil:
    """``step`` solving J^T J step = J^T e (Cholesky of the Jacobi-scaled matrix); False
    when the matrix is singular to rounding (the stars do not fix every parameter)."""
    cdef double scale[_MAX_PARAMS]
    cdef double low[_MAX_PARAMS][_MAX_PARAMS]
    cdef double y[_MAX_PARAMS]
    cdef double t
    cdef int p, q, k
    for p in range(n_params):
        if not n.a[p][p] > 0.0:
            return False
        scale[p] = sqrt(n.a[p][p])
    for p in range(n_params):
        for q in range(p + 1):
            t = n.a[p][q] / (scale[p] * scale[q])
            for k in range(q):
                t -= low[p][k] * low[q][k]
            if p == q:
                if not t > 1e-13:
                    return False
                low[p][p] = sqrt(t)
            else:
                low[p][q] = t / low[q][q]
    for p in range(n_params):
        t = n.b[p] / scale[p]
        for k in range(p):
            t -= low[p][k] * y[k]
        y[p] = t / low[p][p]
    for p in range(n_params - 1, -1, -1):
        t = y[p]
        for k in range(p + 1, n_params):
            t -= low[k][p] * y[k]
        y[p] = t / low[p][p]
    for p in range(n_params):
        step[p] = y[p] / scale[p]
    return True


@cython.cdivision(True)
cdef void _turned(const double[:, ::1] rot, const double* w, double[:, ::1] out) noexcept nogil:
    """``rot`` exp([w]x) into ``out``: the camera frame turned by the small rotation w
    (Rodrigues' formula)."""
    cdef double theta2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2], theta, a, b
    if theta2 < 1e-16:  # the series: sin t / t and (1 - cos t) / t^2 to rounding
        a, b = 1.0 - theta2 / 6.0, 0.5 - theta2 / 24.0
    else:
        theta = sqrt(theta2)
        a, b = sin(theta) / theta, (1.0 - cos(theta)) / theta2
    cdef double e[3][3]
    # I + a [w]x + b [w]x^2, with [w]x^2 = w w^T - |w|^2 I
    e[0][0] = 1.0 + b * (w[0] * w[0] - theta2)
    e[1][1] = 1.0 + b * (w[1] * w[1] - theta2)
    e[2][2] = 1.0 + b * (w[2] * w[2] - theta2)
    e[0][1], e[1][0] = -a * w[2] + b * w[0] * w[1], a * w[2] + b * w[0] * w[1]
    e[0][2], e[2][0] = a * w[1] + b * w[0] * w[2], -a * w[1] + b * w[0] * w[2]
    e[1][2], e[2][1] = -a * w[0] + b * w[1] * w[2], a * w[0] + b * w[1] * w[2]
    cdef int i, j
    for i in range(3):
        for j in range(3):
            out[i, j] = rot[i, 0] * e[0][j] + rot[i, 1] * e[1][j] + rot[i, 2] * e[2][j]


cdef int _least_squares(const Lens* described, const double[:, ::1] cat, double[:, ::1] rot,
                        const double[::1] dx, const double[::1] dy, double* f, double* k1,
                        int n_params, int iterations, double[:, ::1] trial,
                        double* cost) noexcept nogil:
    """Gauss-Newton from ``rot``, ``f``, ``k1`` (all updated in place), at most
    ``iterations`` steps, each halved (up to 10 times, the halves' cost alone evaluated)
    until it lowers the squared residuals; ends when a step would move no parameter
    beyond rounding, lowers them by no more than rounding, or none lowers them. Returns how many steps were taken (-1:
    the normal equations were singular at the start); the sum of the squared residuals
    reached into ``cost``."""
    cdef _Normal here, there
    cdef double step[_MAX_PARAMS]
    cdef double f_new, k1_new, trial_cost
    cdef int it, halvings, p
    cdef bint lowered
    _normal_equations(described, cat, rot, dx, dy, f[0], k1[0], n_params, &here)
    cost[0] = here.cost
    for it in range(iterations):
        if not _solve_normal(&here, n_params, step):
            return -1 if it == 0 else it
        if (fabs(step[3]) <= 1e-13 * fabs(f[0])
                and fabs(step[0]) + fabs(step[1]) + fabs(step[2]) <= 1e-13
                and (n_params < 5 or fabs(step[4]) <= 1e-13)):
            return it  # settled: the step is rounding
        lowered = False
        for halvings in range(10):
            _turned(rot, step, trial)
            f_new = f[0] + step[3]
            k1_new = k1[0] + step[4] if n_params == 5 else k1[0]
            if halvings == 0:  # a full step usually lowers the cost: its equations too
                _normal_equations(described, cat, trial, dx, dy, f_new, k1_new, n_params,
                                  &there)
                trial_cost = there.cost
            else:  # a fit ends on ten halvings that fail: each costs the cost alone
                trial_cost = _cost(described, cat, trial, dx, dy, f_new, k1_new)
            if trial_cost <= here.cost:
                if halvings > 0:
                    _normal_equations(described, cat, trial, dx, dy, f_new, k1_new,
                                      n_params, &there)
                lowered = True
                break
            for p in range(n_params):
                step[p] *= 0.5
        if not lowered:
            return it
        for p in range(3):
            rot[p, 0], rot[p, 1], rot[p, 2] = trial[p, 0], trial[p, 1], trial[p, 2]
        lowered = here.cost - there.cost > 1e-14 * here.cost
        f[0], k1[0], here = f_new, k1_new, there
        cost[0] = here.cost
        if not lowered:
            return it + 1  # settled: the residuals moved by rounding
    return iterations


def focal_error(Optics optics, const double[::1] x, const double[::1] y,
                const double[:, ::1] cat):
    """The standard error of the focal length that the stars at pixels ``x``, ``y``
    (catalog directions ``cat``) fix through camera ``optics``, relative to it, per
    pixel of centroid noise: the focal length's entry of (J^T J)^-1 of the joint least
    squares (the attitude with it, the lens held), at the Wahba attitude of the pairs;
    inf where the stars do not fix it."""
    if y.shape[0] != x.shape[0] or cat.shape[0] != x.shape[0]:
        raise ValueError("focal_error: x, y and cat of unequal lengths")
    return focal_spread(&optics.geometry, x, y, cat)


@cython.cdivision(True)
cdef double focal_spread(const Geometry* g, const double[::1] x, const double[::1] y,
                         const double[:, ::1] cat):
    """:func:`focal_error` of camera ``g`` (C callers: the fitted rounds)."""
    cdef Py_ssize_t m = x.shape[0]
    if m < 2:
        return INFINITY
    cdef double[::1] dx = empty_f64(m), dy = empty_f64(m)
    _offsets(g, x, y, dx, dy)
    cdef double[:, ::1] cam = empty_rows(m, 3), rot = empty_rows(3, 3)
    _directions(g, g.f_px, dx, dy, cam)
    wahba(cam, cat, rot)
    cdef Lens described = lens_of(g)
    cdef _Normal n
    cdef double unit[_MAX_PARAMS]
    _normal_equations(&described, cat, rot, dx, dy, g.f_px, 0.0, 4, &n)
    n.b[0], n.b[1], n.b[2], n.b[3] = 0.0, 0.0, 0.0, 1.0
    if not _solve_normal(&n, 4, unit) or not unit[3] > 0.0:
        return INFINITY
    return sqrt(unit[3]) / g.f_px
