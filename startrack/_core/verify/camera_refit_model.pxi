# The camera model the refit fits (included in camera_refit.pyx): the rotation of a
# rotation vector, the projection of catalog vectors through the seven parameters, the
# mutually nearest pairs of spots and projected stars, the residuals' analytic Jacobian,
# and the 7 x 7 solve of a Levenberg-Marquardt step.

cdef struct Rotation:
    double m[3][3]


cdef Rotation _rotation(const double* w) noexcept nogil:
    """The rotation of rotation vector ``w`` (Rodrigues), as the reference builds it."""
    cdef Rotation out
    cdef double angle = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
    cdef double d = angle if angle > 0 else 1.0
    cdef double k0 = w[0] / d, k1 = w[1] / d, k2 = w[2] / d
    cdef double c[3][3]
    cdef double c2[3][3]
    cdef int i, j, n
    cdef double s = sin(angle), v = 1.0 - cos(angle)
    c[0][0], c[0][1], c[0][2] = 0.0, -k2, k1
    c[1][0], c[1][1], c[1][2] = k2, 0.0, -k0
    c[2][0], c[2][1], c[2][2] = -k1, k0, 0.0
    for i in range(3):
        for j in range(3):
            c2[i][j] = 0.0
            for n in range(3):
                c2[i][j] += c[i][n] * c[n][j]
    for i in range(3):
        for j in range(3):
            out.m[i][j] = (1.0 if i == j else 0.0) + s * c[i][j] + v * c2[i][j]
    return out


cdef void _project(const double* p, const double[:, ::1] v, const Py_ssize_t* rows,
                   Py_ssize_t n, double* px, double* py) noexcept nogil:
    """Pixels of vectors ``v[rows[i]]`` (or ``v[i]`` where ``rows`` is NULL) through ``p``."""
    cdef Rotation r = _rotation(p)
    cdef Py_ssize_t i, k
    cdef double w0, w1, w2, u, t, scale
    for i in range(n):
        k = rows[i] if rows != NULL else i
        w0 = r.m[0][0] * v[k, 0] + r.m[0][1] * v[k, 1] + r.m[0][2] * v[k, 2]
        w1 = r.m[1][0] * v[k, 0] + r.m[1][1] * v[k, 1] + r.m[1][2] * v[k, 2]
        w2 = r.m[2][0] * v[k, 0] + r.m[2][1] * v[k, 1] + r.m[2][2] * v[k, 2]
        u, t = w0 / w2, w1 / w2
        scale = p[3] * (1.0 + p[6] * (u * u + t * t))
        px[i], py[i] = p[4] + u * scale, p[5] + t * scale


cdef Py_ssize_t _pairs(const double* p, const double[:, ::1] v, const double[::1] x,
                       const double[::1] y, double limit, double* px, double* py,
                       Py_ssize_t* spot, Py_ssize_t* star, Py_ssize_t* back,
                       double* back_d, double* d2) noexcept nogil:
    """Mutually nearest (spot, star) pairs within ``limit`` px, spots ascending, each
    pair's squared distance in ``d2``; the count. The first of equal distances is the
    nearest, as numpy's argmin takes it. One pass over the spot-star distances finds both
    sides' nearest (``back``, ``back_d``: each star's nearest spot and its distance,
    scratch of the stars' length); squared distances are compared (a square root per
    candidate was most of a refit)."""
    cdef Py_ssize_t m = v.shape[0], n = x.shape[0], i, j, best, count = 0
    cdef double d, nearest, xi, yi
    _project(p, v, NULL, m, px, py)
    for j in range(m):
        back[j] = -1
    for i in range(n):
        best, nearest, xi, yi = -1, 0.0, x[i], y[i]
        for j in range(m):
            d = (xi - px[j]) * (xi - px[j]) + (yi - py[j]) * (yi - py[j])
            if best < 0 or d < nearest:
                best, nearest = j, d
            if back[j] < 0 or d < back_d[j]:
                back[j], back_d[j] = i, d
        # star[i] and d2[i] hold spot i's star and distance until the pairs are written
        # (at or before i)
        star[i] = best if best >= 0 and nearest <= limit * limit else -1
        d2[i] = nearest
    for i in range(n):
        best = star[i]
        if best >= 0 and back[best] == i:
            spot[count], star[count], d2[count] = i, best, d2[i]
            count += 1
    return count


cdef void _jacobian(const double* p, const double[:, ::1] v, const double[::1] x,
                    const double[::1] y, const Py_ssize_t* spot, const Py_ssize_t* star,
                    Py_ssize_t n, double* r, double* jac) noexcept nogil:
    """Residuals at ``p`` and their Jacobian, analytic. The rotation's columns follow
    from R(w + d) = R(w) Exp(J_r(w) d), J_r being SO(3)'s right Jacobian: the camera-frame
    vector q = R v moves by -[q]x (R J_r) d."""
    cdef Rotation rot = _rotation(p)
    cdef double d[3][3]
    cdef double jr[3][3]
    cdef double k[3][3]
    cdef double k2[3][3]
    cdef double angle = sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]), a, b
    cdef double q0, q1, q2, u, t, rho, scale, dpx_du, dpx_dt, dpy_du, dpy_dt
    cdef double du_dq[3]
    cdef double dt_dq[3]
    cdef double dq[3]
    cdef Py_ssize_t i, c, e, m, row
    # J_r = I - (1 - cos a) / a^2 [w]x + (a - sin a) / a^3 [w]x^2, its series near zero
    if angle > 1e-6:
        a = (1.0 - cos(angle)) / (angle * angle)
        b = (angle - sin(angle)) / (angle * angle * angle)
    else:
        a, b = 0.5, 1.0 / 6.0
    k[0][0], k[0][1], k[0][2] = 0.0, -p[2], p[1]
    k[1][0], k[1][1], k[1][2] = p[2], 0.0, -p[0]
    k[2][0], k[2][1], k[2][2] = -p[1], p[0], 0.0
    for c in range(3):
        for e in range(3):
            k2[c][e] = 0.0
            for m in range(3):
                k2[c][e] += k[c][m] * k[m][e]
    for c in range(3):
        for e in range(3):
            jr[c][e] = (1.0 if c == e else 0.0) - a * k[c][e] + b * k2[c][e]
    for c in range(3):
        for e in range(3):
            d[c][e] = 0.0
            for m in range(3):
                d[c][e] += rot.m[c][m] * jr[m][e]
    for i in range(n):
        row = star[i]
        q0 = rot.m[0][0] * v[row, 0] + rot.m[0][1] * v[row, 1] + rot.m[0][2] * v[row, 2]
        q1 = rot.m[1][0] * v[row, 0] + rot.m[1][1] * v[row, 1] + rot.m[1][2] * v[row, 2]
        q2 = rot.m[2][0] * v[row, 0] + rot.m[2][1] * v[row, 1] + rot.m[2][2] * v[row, 2]
        u, t = q0 / q2, q1 / q2
        rho = u * u + t * t
        scale = p[3] * (1.0 + p[6] * rho)
        r[i], r[n + i] = p[4] + u * scale - x[spot[i]], p[5] + t * scale - y[spot[i]]
        dpx_du = p[3] * (1.0 + p[6] * (rho + 2.0 * u * u))
        dpx_dt = 2.0 * p[3] * p[6] * u * t
        dpy_du = dpx_dt
        dpy_dt = p[3] * (1.0 + p[6] * (rho + 2.0 * t * t))
        du_dq[0], du_dq[1], du_dq[2] = 1.0 / q2, 0.0, -q0 / (q2 * q2)
        dt_dq[0], dt_dq[1], dt_dq[2] = 0.0, 1.0 / q2, -q1 / (q2 * q2)
        for c in range(3):
            # column c of -[q]x D: D's column c crossed with q
            dq[0] = d[1][c] * q2 - d[2][c] * q1
            dq[1] = d[2][c] * q0 - d[0][c] * q2
            dq[2] = d[0][c] * q1 - d[1][c] * q0
            u = du_dq[0] * dq[0] + du_dq[2] * dq[2]
            t = dt_dq[1] * dq[1] + dt_dq[2] * dq[2]
            jac[i * NP + c] = dpx_du * u + dpx_dt * t
            jac[(n + i) * NP + c] = dpy_du * u + dpy_dt * t
        u, t = q0 / q2, q1 / q2
        jac[i * NP + 3], jac[(n + i) * NP + 3] = u * (1.0 + p[6] * rho), t * (1.0 + p[6] * rho)
        jac[i * NP + 4], jac[(n + i) * NP + 4] = 1.0, 0.0
        jac[i * NP + 5], jac[(n + i) * NP + 5] = 0.0, 1.0
        jac[i * NP + 6], jac[(n + i) * NP + 6] = u * p[3] * rho, t * p[3] * rho


cdef bint _solve(double* a, double* b) noexcept nogil:
    """``b`` <- the solution of ``a`` x = ``b`` (NP x NP, partial pivoting); False when
    singular."""
    cdef int i, j, k, pivot
    cdef double f, t
    for k in range(NP):
        pivot = k
        for i in range(k + 1, NP):
            if fabs(a[i * NP + k]) > fabs(a[pivot * NP + k]):
                pivot = i
        if a[pivot * NP + k] == 0.0:
            return False
        if pivot != k:
            for j in range(NP):
                t = a[k * NP + j]
                a[k * NP + j] = a[pivot * NP + j]
                a[pivot * NP + j] = t
            b[k], b[pivot] = b[pivot], b[k]
        for i in range(k + 1, NP):
            f = a[i * NP + k] / a[k * NP + k]
            for j in range(k, NP):
                a[i * NP + j] -= f * a[k * NP + j]
            b[i] -= f * b[k]
    for k in range(NP - 1, -1, -1):
        for j in range(k + 1, NP):
            b[k] -= a[k * NP + j] * b[j]
        b[k] /= a[k * NP + k]
    return True


cdef double _sum_squares(const double* r, Py_ssize_t n) noexcept nogil:
    cdef double s = 0.0
    cdef Py_ssize_t i
    for i in range(n):
        s += r[i] * r[i]
    return s
