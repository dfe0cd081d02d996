# Attitude arithmetic shared by every stage that fits a rotation: Wahba's problem by
# Davenport's q-method (a cyclic Jacobi eigen-solve of the 4 x 4 K matrix), and rotation
# matrix -> quaternion. These run for every hypothesis, where a LAPACK call on a 3 x 3
# matrix costs more in call overhead than in arithmetic.

from libc.math cimport fabs, sqrt


cdef inline void _jacobi_rotate(double[4][4] a, double[4][4] v, int p, int q) noexcept nogil:
    """One Jacobi rotation of the symmetric 4 x 4 ``a`` zeroing a[p][q], accumulated in v."""
    cdef double theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q])
    cdef double t = (1.0 if theta >= 0.0 else -1.0) / (fabs(theta) + sqrt(theta * theta + 1.0))
    cdef double c = 1.0 / sqrt(t * t + 1.0)
    cdef double s = t * c
    cdef double x, y
    cdef int r
    for r in range(4):
        x, y = a[r][p], a[r][q]
        a[r][p], a[r][q] = c * x - s * y, s * x + c * y
    for r in range(4):
        x, y = a[p][r], a[q][r]
        a[p][r], a[q][r] = c * x - s * y, s * x + c * y
    for r in range(4):
        x, y = v[r][p], v[r][q]
        v[r][p], v[r][q] = c * x - s * y, s * x + c * y


cdef inline void _top_eigenvector(double[4][4] k, double[4] out) noexcept nogil:
    """The eigenvector of the largest eigenvalue of a symmetric 4 x 4 matrix (cyclic
    Jacobi: accurate to rounding however close the other eigenvalues come, which a narrow
    field makes them). ``k`` is overwritten."""
    cdef double[4][4] v
    cdef int i, j, p, q, sweep, best = 0
    cdef double off
    for i in range(4):
        for j in range(4):
            v[i][j] = 1.0 if i == j else 0.0
    cdef double scale = k[0][0] ** 2 + k[1][1] ** 2 + k[2][2] ** 2 + k[3][3] ** 2
    for sweep in range(30):
        off = 0.0
        for p in range(3):
            for q in range(p + 1, 4):
                off += k[p][q] * k[p][q]
        if off <= 1e-30 * scale:
            break
        for p in range(3):
            for q in range(p + 1, 4):
                if k[p][q] != 0.0:
                    _jacobi_rotate(k, v, p, q)
    for i in range(1, 4):
        if k[i][i] > k[best][best]:
            best = i
    for i in range(4):
        out[i] = v[i][best]


cdef inline void wahba(const double[:, :] cam, const double[:, :] sky,
                       double[:, :] r) noexcept nogil:
    """The rotation matrix ``r`` (3 x 3, written) minimising sum |sky_k - r cam_k|^2 over
    the (m, 3) vector pairs: Davenport's q-method, the quaternion maximising q^T K q."""
    cdef double[3][3] b
    cdef double[4][4] k
    cdef double[4] q
    cdef Py_ssize_t n
    cdef int i, j
    for i in range(3):
        for j in range(3):
            b[i][j] = 0.0
    for n in range(cam.shape[0]):
        for i in range(3):
            for j in range(3):
                b[i][j] += sky[n, i] * cam[n, j]
    cdef double sigma = b[0][0] + b[1][1] + b[2][2]
    k[0][0] = sigma
    k[0][1] = k[1][0] = b[1][2] - b[2][1]
    k[0][2] = k[2][0] = b[2][0] - b[0][2]
    k[0][3] = k[3][0] = b[0][1] - b[1][0]
    for i in range(3):
        for j in range(3):
            k[i + 1][j + 1] = b[i][j] + b[j][i] - (sigma if i == j else 0.0)
    _top_eigenvector(k, q)
    cdef double w = q[0], x = -q[1], y = -q[2], z = -q[3]  # K's vector part: the inverse
    r[0, 0], r[0, 1], r[0, 2] = 1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)
    r[1, 0], r[1, 1], r[1, 2] = 2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)
    r[2, 0], r[2, 1], r[2, 2] = 2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)


cdef inline void matrix_to_quaternion(const double[:, :] m, double[::1] out) noexcept nogil:
    """Unit quaternion of a rotation matrix, scalar LAST ``[x, y, z, w]`` as scipy's
    ``Rotation.from_quat`` takes it fastest, w >= 0 (Shepperd's method)."""
    cdef double[4] q
    cdef double tr = m[0, 0] + m[1, 1] + m[2, 2]
    if tr >= m[0, 0] and tr >= m[1, 1] and tr >= m[2, 2]:
        q[0] = 1.0 + tr
        q[1], q[2], q[3] = m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1]
    elif m[0, 0] >= m[1, 1] and m[0, 0] >= m[2, 2]:
        q[0], q[1] = m[2, 1] - m[1, 2], 1.0 + 2.0 * m[0, 0] - tr
        q[2], q[3] = m[0, 1] + m[1, 0], m[0, 2] + m[2, 0]
    elif m[1, 1] >= m[2, 2]:
        q[0], q[1] = m[0, 2] - m[2, 0], m[0, 1] + m[1, 0]
        q[2], q[3] = 1.0 + 2.0 * m[1, 1] - tr, m[1, 2] + m[2, 1]
    else:
        q[0], q[1] = m[1, 0] - m[0, 1], m[0, 2] + m[2, 0]
        q[2], q[3] = m[1, 2] + m[2, 1], 1.0 + 2.0 * m[2, 2] - tr
    cdef double norm = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    cdef double sign = -1.0 if q[0] / norm < 0.0 else 1.0
    out[0], out[1], out[2], out[3] = (sign * (q[1] / norm), sign * (q[2] / norm),
                                      sign * (q[3] / norm), sign * (q[0] / norm))
