# How far the refitted camera moves the image centre, and that move's 1-sigma (included
# in camera_refit.pyx): the fit's covariance from its normal matrix (a pseudo-inverse, as
# numpy's pinv: the principal point and the attitude nearly trade off, and a star set
# may leave a direction unconstrained), pushed through the centre's gradient.


cdef void _centre(const double* p, double x, double y, double* cu,
                  double* cv) noexcept nogil:
    cdef double du = (x - p[4]) / p[3], dv = (y - p[5]) / p[3], u = du, t = dv, s
    cdef Rotation r = _rotation(&p[0])
    cdef int i
    for i in range(8):
        s = 1.0 + p[6] * (u * u + t * t)
        u, t = du / s, dv / s
    # the inverse rotation: the transpose
    cdef double w0 = r.m[0][0] * u + r.m[1][0] * t + r.m[2][0]
    cdef double w1 = r.m[0][1] * u + r.m[1][1] * t + r.m[2][1]
    cdef double w2 = r.m[0][2] * u + r.m[1][2] * t + r.m[2][2]
    cu[0], cv[0] = w0 / w2, w1 / w2


cdef void _symmetric_pinv(const double* a, double* out) noexcept nogil:
    """``out`` <- the pseudo-inverse of the symmetric positive semi-definite NP x NP
    ``a``: its diagonal scaled to one (the parameters' units span a dozen orders), cyclic
    Jacobi rotations to its eigenvectors, eigenvalues at most 1e-15 of the largest taken
    as zero (numpy's pinv cut-off), the scaling undone."""
    cdef double m[NP * NP]
    cdef double vec[NP * NP]
    cdef double scale[NP]
    cdef double inv[NP]
    cdef double off, diag, theta, t, c, s, x, z, largest
    cdef int i, j, k, q, sweep
    for i in range(NP):
        scale[i] = 1.0 / sqrt(a[i * NP + i]) if a[i * NP + i] > 0.0 else 0.0
    for i in range(NP):
        for j in range(NP):
            m[i * NP + j] = a[i * NP + j] * scale[i] * scale[j]
            vec[i * NP + j] = 1.0 if i == j else 0.0
    for sweep in range(60):
        off, diag = 0.0, 0.0
        for i in range(NP):
            diag += m[i * NP + i] * m[i * NP + i]
            for j in range(i + 1, NP):
                off += m[i * NP + j] * m[i * NP + j]
        if off <= 1e-32 * diag:
            break
        for i in range(NP):
            for q in range(i + 1, NP):
                if m[i * NP + q] == 0.0:
                    continue
                # the rotation that zeroes (i, q): the smaller root of t^2 - 2 theta t - 1
                theta = (m[i * NP + i] - m[q * NP + q]) / (2.0 * m[i * NP + q])
                t = 1.0 / (fabs(theta) + sqrt(theta * theta + 1.0))
                t = -t if theta > 0.0 else t
                c = 1.0 / sqrt(t * t + 1.0)
                s = t * c
                for k in range(NP):
                    x, z = m[k * NP + i], m[k * NP + q]
                    m[k * NP + i], m[k * NP + q] = c * x - s * z, s * x + c * z
                for k in range(NP):
                    x, z = m[i * NP + k], m[q * NP + k]
                    m[i * NP + k], m[q * NP + k] = c * x - s * z, s * x + c * z
                for k in range(NP):
                    x, z = vec[k * NP + i], vec[k * NP + q]
                    vec[k * NP + i], vec[k * NP + q] = c * x - s * z, s * x + c * z
    largest = 0.0
    for i in range(NP):
        largest = max(largest, fabs(m[i * NP + i]))
    for i in range(NP):
        inv[i] = 1.0 / m[i * NP + i] if fabs(m[i * NP + i]) > 1e-15 * largest else 0.0
    for i in range(NP):
        for j in range(NP):
            x = 0.0
            for k in range(NP):
                x += vec[i * NP + k] * inv[k] * vec[j * NP + k]
            out[i * NP + j] = x * scale[i] * scale[j]


cdef void _centre_move(const double* p, const double* jtj, double variance, double cx0,
                       double cy0, double given_u, double given_v, double f_px,
                       double* shift, double* sigma) noexcept nogil:
    """The image centre's move (px) from the given camera's direction (``given_u``,
    ``given_v``) to the refitted ``p``'s, and its 1-sigma: the covariance ``variance``
    x pinv(``jtj``) through the centre's forward-difference gradient, each parameter
    stepped by 1e-3 of its own 1-sigma."""
    cdef double cov[NP * NP]
    cdef double grad[2 * NP]
    cdef double q[NP]
    cdef double u0, t0, u, t, step, total = 0.0
    cdef int k, c
    _symmetric_pinv(jtj, cov)
    for k in range(NP * NP):
        cov[k] *= variance
    _centre(p, cx0, cy0, &u0, &t0)
    for k in range(NP):
        step = sqrt(max(cov[k * NP + k], 0.0)) * 1e-3 + 1e-12
        for c in range(NP):
            q[c] = p[c]
        q[k] += step
        _centre(q, cx0, cy0, &u, &t)
        grad[k], grad[NP + k] = (u - u0) / (q[k] - p[k]), (t - t0) / (q[k] - p[k])
    for k in range(NP):
        for c in range(NP):
            total += (grad[k] * grad[c] + grad[NP + k] * grad[NP + c]) * cov[k * NP + c]
    shift[0] = sqrt((u0 - given_u) ** 2 + (t0 - given_v) ** 2) * f_px
    sigma[0] = sqrt(max(total, 0.0)) * f_px


def centre(const double[::1] p, double x, double y):
    """Tangent-plane direction (u, v), in the answer's camera frame, of pixel (x, y)
    through ``p`` (k1 inverted by eight fixed-point steps: small near the centre)."""
    cdef double u, t
    _centre(&p[0], x, y, &u, &t)
    return u, t


def symmetric_pinv(const double[:, ::1] a):
    """The pseudo-inverse of a symmetric positive semi-definite 7 x 7 matrix, as the
    refit's covariance takes it (its tests hold it to numpy's pinv)."""
    out = np.empty((NP, NP))
    cdef double[:, ::1] o = out
    _symmetric_pinv(&a[0, 0], &o[0, 0])
    return out
