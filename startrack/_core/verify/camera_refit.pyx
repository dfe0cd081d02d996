"""The camera refit's arithmetic (startrack.verify._refit): the mutually nearest pairs of
spots and projected catalog stars, and the Levenberg-Marquardt fit of attitude, focal
length, principal point and k1 to them, round after round, with nothing per pair or per
step in Python (the numpy version cost about 1.5 ms an answer, most of a solve).

The parameters are seven: a rotation vector (3) applied to the answer's camera-frame
vectors, the focal length, the principal point (2) and k1. The steps are the numpy
reference's in the tests (column-normalised damping, the same acceptance and stopping
rules), with the Jacobian analytic where the reference takes forward differences: the two
settle on the same camera within the fit's stopping tolerance.
"""

cimport cython
import numpy as np

from libc.math cimport cos, fabs, sin, sqrt
from libc.stdlib cimport free, malloc

cdef enum:
    NP = 7  # parameters: rotation vector (3), focal length, principal point (2), k1


include "camera_refit_model.pxi"


cdef Py_ssize_t _pairs(const double* p, const double[:, ::1] v, const double[::1] x,
                       const double[::1] y, double limit, double* px, double* py,
                       Py_ssize_t* spot, Py_ssize_t* star) noexcept nogil:
    """Mutually nearest (spot, star) pairs within ``limit`` px, spots ascending; the
    count. The first of equal distances is the nearest, as numpy's argmin takes it."""
    cdef Py_ssize_t m = v.shape[0], n = x.shape[0], i, j, best, back, count = 0
    cdef double d, nearest
    _project(p, v, NULL, m, px, py)
    for i in range(n):
        best, nearest = -1, 0.0
        for j in range(m):
            d = sqrt((x[i] - px[j]) ** 2 + (y[i] - py[j]) ** 2)
            if best < 0 or d < nearest:
                best, nearest = j, d
        if best < 0 or not nearest <= limit:
            continue
        back, nearest = -1, 0.0
        for j in range(n):
            d = sqrt((x[j] - px[best]) ** 2 + (y[j] - py[best]) ** 2)
            if back < 0 or d < nearest:
                back, nearest = j, d
        if back == i:
            spot[count], star[count] = i, best
            count += 1
    return count


cdef struct Fit:
    double r2        # the residuals' sum of squares
    double* r        # residuals, x then y (2n)
    double* jac      # their Jacobian, 2n x NP, row-major
    double* trial_r  # a trial step's residuals
    double* a        # the Jacobian with its columns scaled, 2n x NP
    double* px       # projection scratch, NP + 1 parameter sets of n
    double* py


cdef bint _fit(double* p, const double[:, ::1] v, const double[::1] x, const double[::1] y,
               const Py_ssize_t* spot, const Py_ssize_t* star, Py_ssize_t n, bint free_k1,
               Py_ssize_t iterations, double damping,
               Fit* fit) noexcept nogil:
    """Levenberg-Marquardt from ``p`` (k1 held unless ``free_k1``): ``p``, ``fit.r`` and
    ``fit.jac`` left at the best parameters found; False when a step cannot be solved."""
    cdef double norm[NP]
    cdef double h[NP * NP]
    cdef double g[NP]
    cdef double trial[NP]
    cdef double a_i, r2t
    cdef Py_ssize_t i, j, c, rows = 2 * n
    cdef bint small
    _jacobian(p, v, x, y, spot, star, n, fit.r, fit.jac)
    fit.r2 = _sum_squares(fit.r, rows)
    for _ in range(iterations):
        for c in range(NP):
            norm[c] = 0.0
            for i in range(rows):
                norm[c] += fit.jac[i * NP + c] * fit.jac[i * NP + c]
            norm[c] = sqrt(norm[c])
            if norm[c] == 0.0 or (c == NP - 1 and not free_k1):
                norm[c] = 1.0
        # the Jacobian's columns scaled to unit length (the held k1's zeroed), then the
        # normal equations of the scaled problem, their lower triangle mirrored
        for i in range(rows):
            for c in range(NP):
                fit.a[i * NP + c] = fit.jac[i * NP + c] / norm[c]
            if not free_k1:
                fit.a[i * NP + NP - 1] = 0.0
        for c in range(NP):
            g[c] = 0.0
            for j in range(c + 1):
                h[c * NP + j] = 0.0
        for i in range(rows):
            for c in range(NP):
                a_i = fit.a[i * NP + c]
                g[c] -= a_i * fit.r[i]
                for j in range(c + 1):
                    h[c * NP + j] += a_i * fit.a[i * NP + j]
        for c in range(NP):
            for j in range(c + 1, NP):
                h[c * NP + j] = h[j * NP + c]
        for c in range(NP):
            h[c * NP + c] += damping * h[c * NP + c] + 1e-12
        if not _solve(h, g):
            return False
        small = True
        for c in range(NP):
            g[c] /= norm[c]
            trial[c] = p[c] + g[c]
            small = small and fabs(g[c]) <= 1e-7 * (1.0 + fabs(p[c]))
        _project(trial, v, star, n, fit.px, fit.py)
        for i in range(n):
            fit.trial_r[i] = fit.px[i] - x[spot[i]]
            fit.trial_r[n + i] = fit.py[i] - y[spot[i]]
        r2t = _sum_squares(fit.trial_r, rows)
        if r2t < fit.r2:
            small = True
            for c in range(NP):
                p[c] = trial[c]
                small = small and fabs(g[c]) <= 1e-7 * (1.0 + fabs(p[c]))
            _jacobian(p, v, x, y, spot, star, n, fit.r, fit.jac)
            fit.r2, damping = r2t, damping / 10.0
            if small:
                break
        else:
            # a step this small that does not lower the residuals: at the minimum, to
            # rounding (raising the damping a dozen times more found nothing)
            damping *= 10.0
            if damping > 1e8 or small:
                break
    return True


cdef class _Work:
    """The fit's scratch arrays, sized for ``n`` spots and ``m`` catalog stars."""
    cdef Fit fit
    cdef Py_ssize_t* spot
    cdef Py_ssize_t* star

    def __cinit__(self, Py_ssize_t n, Py_ssize_t m):
        cdef Py_ssize_t width = max(m, 2 * n, 1)
        self.fit.r = <double*>malloc(2 * max(n, 1) * sizeof(double))
        self.fit.trial_r = <double*>malloc(2 * max(n, 1) * sizeof(double))
        self.fit.jac = <double*>malloc(2 * max(n, 1) * NP * sizeof(double))
        self.fit.a = <double*>malloc(2 * max(n, 1) * NP * sizeof(double))
        self.fit.px = <double*>malloc(width * sizeof(double))
        self.fit.py = <double*>malloc(width * sizeof(double))
        self.spot = <Py_ssize_t*>malloc(max(n, 1) * sizeof(Py_ssize_t))
        self.star = <Py_ssize_t*>malloc(max(n, 1) * sizeof(Py_ssize_t))
        if (self.fit.r == NULL or self.fit.trial_r == NULL or self.fit.jac == NULL
                or self.fit.a == NULL or self.fit.px == NULL or self.fit.py == NULL or self.spot == NULL
                or self.star == NULL):
            raise MemoryError("camera refit: scratch arrays")

    def __dealloc__(self):
        free(self.fit.r)
        free(self.fit.trial_r)
        free(self.fit.jac)
        free(self.fit.a)
        free(self.fit.px)
        free(self.fit.py)
        free(self.spot)
        free(self.star)


def pairs(const double[::1] p, const double[:, ::1] v, const double[::1] x,
          const double[::1] y, double limit):
    """(spots, stars): the mutually nearest pairs of spots (``x``, ``y``) and catalog
    stars (camera-frame vectors ``v``) through parameters ``p``, within ``limit`` px."""
    cdef _Work work = _Work(x.shape[0], v.shape[0])
    cdef Py_ssize_t count, i
    with nogil:
        count = _pairs(&p[0], v, x, y, limit, work.fit.px, work.fit.py, work.spot, work.star)
    spots, stars = np.empty(count, np.int64), np.empty(count, np.int64)
    cdef long long[::1] a = spots, b = stars
    for i in range(count):
        a[i], b[i] = work.spot[i], work.star[i]
    return spots, stars


def fit_rounds(double[::1] p, const double[:, ::1] v, const double[::1] x,
               const double[::1] y, double radius_px, const double[::1] factors,
               const unsigned char[::1] free_k1, Py_ssize_t min_pairs,
               Py_ssize_t iterations, double damping):
    """Fit ``p`` in place, one round per pairing radius (``factors`` x ``radius_px``; k1
    free where ``free_k1``): (the last round's residual sum of squares, its residual
    count, J^T J of its Jacobian), or None when a round pairs fewer than ``min_pairs``."""
    cdef _Work work = _Work(x.shape[0], v.shape[0])
    cdef Py_ssize_t r, count = 0, i, c, j
    cdef bint ok = True
    with nogil:
        for r in range(factors.shape[0]):
            count = _pairs(&p[0], v, x, y, factors[r] * radius_px, work.fit.px,
                           work.fit.py, work.spot, work.star)
            if count < min_pairs:
                ok = False
                break
            if not _fit(&p[0], v, x, y, work.spot, work.star, count, free_k1[r],
                        iterations, damping, &work.fit):
                ok = False
                break
    if not ok:
        return None
    jtj = np.zeros((NP, NP))
    cdef double[:, ::1] out = jtj
    for i in range(2 * count):
        for c in range(NP):
            for j in range(NP):
                out[c, j] += work.fit.jac[i * NP + c] * work.fit.jac[i * NP + j]
    return work.fit.r2, 2 * count, jtj


def centre(const double[::1] p, double x, double y):
    """Tangent-plane direction (u, v), in the answer's camera frame, of pixel (x, y)
    through ``p`` (k1 inverted by eight fixed-point steps: small near the centre)."""
    cdef double u, t
    _centre(&p[0], x, y, &u, &t)
    return u, t


def centre_gradient(const double[::1] p, double x, double y, const double[::1] steps):
    """The 2 x 7 forward-difference gradient of :func:`centre` at ``p``, parameter k
    moved by ``steps[k]``."""
    grad = np.empty((2, NP))
    cdef double[:, ::1] out = grad
    cdef double q[NP]
    cdef double u0, t0, u, t
    cdef int k, c
    _centre(&p[0], x, y, &u0, &t0)
    for k in range(NP):
        for c in range(NP):
            q[c] = p[c]
        q[k] += steps[k]
        _centre(q, x, y, &u, &t)
        out[0, k] = (u - u0) / (q[k] - p[k])
        out[1, k] = (t - t0) / (q[k] - p[k])
    return grad


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
