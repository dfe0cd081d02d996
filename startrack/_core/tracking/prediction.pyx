"""The attitude prediction of tracking: the next frame's attitude and its error from the
last two solved ones, and rotation matrix <-> rotation vector (scipy's Rotation costs tens
of microseconds a call, more than the arithmetic)."""

import numpy as np

from libc.math cimport acos, cos, hypot, sin, sqrtl


cdef double _norm3(const double* v) noexcept nogil:
    """|v| as BLAS's dnrm2 gives it (the squares summed in x87 extended precision), so
    that predictions are those of the numpy-based code to the last bit."""
    cdef long double x = v[0], y = v[1], z = v[2]
    return <double>sqrtl(x * x + y * y + z * z)


cdef void _mul(const double[:, :] a, const double[:, :] b, double[:, ::1] out) noexcept nogil:
    """out = a @ b for 3 x 3 matrices (each element a 3-term sum in order)."""
    cdef Py_ssize_t i, j
    for i in range(3):
        for j in range(3):
            out[i, j] = a[i, 0] * b[0, j] + a[i, 1] * b[1, j] + a[i, 2] * b[2, j]


cdef void _exp(const double* rotvec, double[:, ::1] out) noexcept nogil:
    """The rotation matrix of a rotation vector (Rodrigues)."""
    cdef double angle = _norm3(rotvec), k[3], s, c, kx[3][3], kk
    cdef Py_ssize_t i, j
    for i in range(3):
        for j in range(3):
            out[i, j] = 1.0 if i == j else 0.0
    if angle < 1e-15:
        return
    for i in range(3):
        k[i] = rotvec[i] / angle
    kx[0][0], kx[0][1], kx[0][2] = 0.0, -k[2], k[1]
    kx[1][0], kx[1][1], kx[1][2] = k[2], 0.0, -k[0]
    kx[2][0], kx[2][1], kx[2][2] = -k[1], k[0], 0.0
    s, c = sin(angle), 1.0 - cos(angle)
    for i in range(3):
        for j in range(3):
            kk = kx[i][0] * kx[0][j] + kx[i][1] * kx[1][j] + kx[i][2] * kx[2][j]
            out[i, j] = (out[i, j] + s * kx[i][j]) + c * kk


cdef void _log(const double[:, :] m, double* out) noexcept nogil:
    """The rotation vector of a rotation matrix (angles well below pi: frame to frame)."""
    cdef double cs = min(1.0, max(-1.0, (0.0 + m[0, 0] + m[1, 1] + m[2, 2] - 1.0) / 2.0))
    cdef double angle = acos(cs), f
    cdef Py_ssize_t i
    out[0] = m[2, 1] - m[1, 2]
    out[1] = m[0, 2] - m[2, 0]
    out[2] = m[1, 0] - m[0, 1]
    if angle < 1e-7:
        for i in range(3):
            out[i] = out[i] / 2.0
        return
    f = angle / (2.0 * sin(angle))
    for i in range(3):
        out[i] = out[i] * f


def rotation_exp(const double[::1] rotvec):
    """The rotation matrix of a rotation vector (Rodrigues), without scipy's overhead."""
    out = np.empty((3, 3))
    _exp(&rotvec[0], out)
    return out


def rotation_log(const double[:, :] matrix):
    """The rotation vector of a rotation matrix (angles well below pi: frame to frame)."""
    out = np.empty(3)
    cdef double[::1] v = out
    _log(matrix, &v[0])
    return out


cdef class Motion:
    """How the attitude error grows: ``unknown_rate`` (rad a frame) while no rate is
    known; once it is, the two attitudes' errors over the gap, ``accel_fraction`` of the
    rate (angular acceleration) and ``rate_floor`` (jitter), a frame."""

    cdef readonly double unknown_rate, accel_fraction, rate_floor

    def __init__(self, double unknown_rate, double accel_fraction, double rate_floor):
        self.unknown_rate = unknown_rate
        self.accel_fraction = accel_fraction
        self.rate_floor = rate_floor


def predict_attitude(const double[:, :] rot_a, const double[:, :] rot_b, long gap, long steps,
                     double sig_a, double sig_b, Motion motion):
    """The attitude ``steps`` frames after ``rot_b`` (camera to sky) and its 1-sigma error:
    the per-frame rotation from ``rot_a``, ``gap`` frames before ``rot_b`` (R_b = R_a
    exp(w gap), in the camera frame), carried forward; with ``gap`` 0 there is no rate
    yet and the error grows by ``motion.unknown_rate`` a frame."""
    cdef double rate[3], sig_w = motion.unknown_rate
    cdef double[:, ::1] rel = np.empty((3, 3)), step = np.empty((3, 3))
    cdef Py_ssize_t i
    rate[0] = rate[1] = rate[2] = 0.0
    if gap > 0:
        _mul(rot_a.T, rot_b, rel)
        _log(rel, rate)
        for i in range(3):
            rate[i] = rate[i] / gap
        sig_w = (hypot(sig_a, sig_b) / gap + motion.accel_fraction * _norm3(rate)
                 + motion.rate_floor)
    for i in range(3):
        rate[i] = rate[i] * steps
    _exp(rate, step)
    out = np.empty((3, 3))
    _mul(rot_b, step, out)
    return out, sig_b + steps * sig_w
