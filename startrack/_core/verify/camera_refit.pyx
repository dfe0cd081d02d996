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

from startrack._core.camera.lens cimport Geometry, Lens, lens_factor, lens_is_identity, lens_of
from startrack._core.camera.optics cimport Optics, unit_vectors

cdef enum:
    NP = 7  # parameters: rotation vector (3), focal length, principal point (2), k1


include "camera_refit_model.pxi"
include "camera_refit_move.pxi"
include "camera_refit_view.pxi"


cdef struct Fit:
    double r2        # the residuals' sum of squares
    double* r        # residuals, x then y (2n)
    double* jac      # their Jacobian, 2n x NP, row-major
    double jtj[NP * NP]  # J^T J
    double jtr[NP]   # J^T r
    double* trial_r  # a trial step's residuals
    double* px       # projection scratch, NP + 1 parameter sets of n
    double* py


cdef void _normal(Fit* fit, Py_ssize_t rows) noexcept nogil:
    """The fit's J^T J (lower triangle mirrored) and J^T r, from its Jacobian."""
    cdef Py_ssize_t i, c, j
    cdef double a_i
    for c in range(NP):
        fit.jtr[c] = 0.0
        for j in range(c + 1):
            fit.jtj[c * NP + j] = 0.0
    for i in range(rows):
        for c in range(NP):
            a_i = fit.jac[i * NP + c]
            fit.jtr[c] += a_i * fit.r[i]
            for j in range(c + 1):
                fit.jtj[c * NP + j] += a_i * fit.jac[i * NP + j]
    for c in range(NP):
        for j in range(c + 1, NP):
            fit.jtj[c * NP + j] = fit.jtj[j * NP + c]


cdef bint _fit(double* p, const double[:, ::1] v, const double[::1] x, const double[::1] y,
               const Py_ssize_t* spot, const Py_ssize_t* star, Py_ssize_t n, bint free_k1,
               Py_ssize_t iterations, double damping,
               Fit* fit) noexcept nogil:
    """Levenberg-Marquardt from ``p`` (k1 held unless ``free_k1``): ``p``, ``fit.r`` and
    ``fit.jac`` left at the best parameters found; False when a step cannot be solved.
    The scaled normal equations come from J^T J, formed once per accepted step (a
    rejected step only raises the damping)."""
    cdef double norm[NP]
    cdef double h[NP * NP]
    cdef double g[NP]
    cdef double trial[NP]
    cdef double r2t
    cdef Py_ssize_t i, j, c, rows = 2 * n
    cdef bint small
    _jacobian(p, v, x, y, spot, star, n, fit.r, fit.jac)
    _normal(fit, rows)
    fit.r2 = _sum_squares(fit.r, rows)
    for _ in range(iterations):
        # the Jacobian's columns scaled to unit length, the held k1's zeroed
        for c in range(NP):
            norm[c] = sqrt(fit.jtj[c * NP + c])
            if norm[c] == 0.0 or (c == NP - 1 and not free_k1):
                norm[c] = 1.0
        for c in range(NP):
            g[c] = -fit.jtr[c] / norm[c]
            for j in range(NP):
                h[c * NP + j] = fit.jtj[c * NP + j] / (norm[c] * norm[j])
        if not free_k1:
            g[NP - 1] = 0.0
            for c in range(NP):
                h[c * NP + NP - 1], h[(NP - 1) * NP + c] = 0.0, 0.0
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
            _normal(fit, rows)
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
    cdef Py_ssize_t* back  # each catalog star's nearest spot, and its distance
    cdef double* back_d
    cdef double* d2  # the pairs' squared distances
    cdef bint fresh  # the pairs in hand were made through the parameters as they are
    cdef double limit  # ... within this many px

    cdef Py_ssize_t pair_within(self, const double* p, const double[:, ::1] v,
                                const double[::1] x, const double[::1] y, double limit,
                                Py_ssize_t count) noexcept nogil:
        """The mutually nearest pairs within ``limit`` px through ``p``: those of the
        ``count`` in hand within ``limit`` where they were made through this ``p`` within a
        wider one (which are mutually nearest does not depend on it), else :func:`_pairs`."""
        cdef Py_ssize_t k, kept = 0
        if self.fresh and limit <= self.limit:
            for k in range(count):
                if self.d2[k] <= limit * limit:
                    self.spot[kept], self.star[kept] = self.spot[k], self.star[k]
                    self.d2[kept] = self.d2[k]
                    kept += 1
        else:
            kept = _pairs(p, v, x, y, limit, self.fit.px, self.fit.py, self.spot,
                          self.star, self.back, self.back_d, self.d2)
        self.fresh, self.limit = True, limit
        return kept

    def __cinit__(self, Py_ssize_t n, Py_ssize_t m):
        cdef Py_ssize_t width = max(m, 2 * n, 1)
        self.fit.r = <double*>malloc(2 * max(n, 1) * sizeof(double))
        self.fit.trial_r = <double*>malloc(2 * max(n, 1) * sizeof(double))
        self.fit.jac = <double*>malloc(2 * max(n, 1) * NP * sizeof(double))
        self.fit.px = <double*>malloc(width * sizeof(double))
        self.fit.py = <double*>malloc(width * sizeof(double))
        # pairs, then the last round's pairs
        self.spot = <Py_ssize_t*>malloc(2 * max(n, 1) * sizeof(Py_ssize_t))
        self.star = <Py_ssize_t*>malloc(2 * max(n, 1) * sizeof(Py_ssize_t))
        self.back = <Py_ssize_t*>malloc(max(m, 1) * sizeof(Py_ssize_t))
        self.back_d = <double*>malloc(max(m, 1) * sizeof(double))
        self.d2 = <double*>malloc(max(n, 1) * sizeof(double))  # fresh: False, as allocated
        if (self.fit.r == NULL or self.fit.trial_r == NULL or self.fit.jac == NULL
                or self.fit.px == NULL or self.fit.py == NULL or self.spot == NULL
                or self.star == NULL or self.back == NULL or self.back_d == NULL
                or self.d2 == NULL):
            raise MemoryError("camera refit: scratch arrays")

    def __dealloc__(self):
        free(self.fit.r)
        free(self.fit.trial_r)
        free(self.fit.jac)
        free(self.fit.px)
        free(self.fit.py)
        free(self.spot)
        free(self.star)
        free(self.back)
        free(self.back_d)
        free(self.d2)


include "camera_refit_k1.pxi"


def pairs(const double[::1] p, const double[:, ::1] v, const double[::1] x,
          const double[::1] y, double limit):
    """(spots, stars): the mutually nearest pairs of spots (``x``, ``y``) and catalog
    stars (camera-frame vectors ``v``) through parameters ``p``, within ``limit`` px."""
    cdef _Work work = _Work(x.shape[0], v.shape[0])
    cdef Py_ssize_t count, i
    count = work.pair_within(&p[0], v, x, y, limit, 0)
    spots, stars = np.empty(count, np.int64), np.empty(count, np.int64)
    cdef long long[::1] a = spots, b = stars
    for i in range(count):
        a[i], b[i] = work.spot[i], work.star[i]
    return spots, stars


cdef class RefitRules:
    """The refit's rounds and stopping rules: each round's pairing radius in match radii
    (``factors``) and whether k1 is free in it (``free_k1``, 0 or 1), the fewest pairs a
    round fits (``min_pairs``), Levenberg-Marquardt steps per round at most
    (``iterations``), the first step's damping (``damping``) and ``k1_chi2``: the rounds
    that free k1 are not run where k1's score at the fit that held it is within this
    chi-square of one degree of freedom (:func:`_k1_unsupported`; 0: always run)."""
    cdef readonly object factors, free_k1
    cdef const double[::1] _factors
    cdef const unsigned char[::1] _free
    cdef readonly Py_ssize_t min_pairs, iterations
    cdef readonly double damping, k1_chi2

    def __init__(self, factors, free_k1, Py_ssize_t min_pairs, Py_ssize_t iterations,
                 double damping, double k1_chi2=0.0):
        self.factors = np.ascontiguousarray(factors, np.float64)
        self.free_k1 = np.ascontiguousarray(free_k1, np.uint8)
        if len(self.factors) != len(self.free_k1) or len(self.factors) == 0:
            raise ValueError("RefitRules: one k1 flag per round, at least one round")
        self._factors, self._free = self.factors, self.free_k1
        self.min_pairs, self.iterations, self.damping = min_pairs, iterations, damping
        self.k1_chi2 = k1_chi2


cdef bint _fit_rounds(double* p, const double[:, ::1] v, const double[::1] x,
                      const double[::1] y, double radius_px, RefitRules rules, _Work work,
                      Py_ssize_t* count) noexcept:
    """:func:`fit_rounds`' rounds, the last round's pairs left in ``work``. A round
    that pairs the same stars as the last, with k1 as free, is not fitted again: the
    last fit ended at its minimum (fitting again took one step of 1e-7 relative)."""
    cdef Py_ssize_t r, k, n = x.shape[0], last = -1
    cdef bint same
    for r in range(rules._factors.shape[0]):
        if r > 0 and rules._free[r] and not rules._free[r - 1] and rules.k1_chi2 > 0.0 \
                and _k1_unsupported(&work.fit, 2 * last, rules.k1_chi2):
            return True  # freeing k1 would move the fit by less than the noise
        for k in range(max(last, 0)):
            work.spot[n + k], work.star[n + k] = work.spot[k], work.star[k]
        count[0] = work.pair_within(p, v, x, y, rules._factors[r] * radius_px, max(last, 0))
        if count[0] < rules.min_pairs:
            return False
        same = count[0] == last and rules._free[r] == rules._free[r - 1]
        k = 0
        while same and k < count[0]:
            same = work.spot[k] == work.spot[n + k] and work.star[k] == work.star[n + k]
            k += 1
        work.fresh = work.fresh and same  # a fit moves what the pairs were made through
        if not same and not _fit(p, v, x, y, work.spot, work.star, count[0], rules._free[r],
                                 rules.iterations, rules.damping, &work.fit):
            return False
        last = count[0]
    return True


def fit_rounds(double[::1] p, const double[:, ::1] v, const double[::1] x,
               const double[::1] y, double radius_px, RefitRules rules):
    """Fit ``p`` in place, one round per pairing radius (``rules``, in match radii of
    ``radius_px``): (the last round's residual sum of squares, its residual count, J^T J
    of its Jacobian), or None when a round pairs fewer than ``rules.min_pairs``."""
    cdef _Work work = _Work(x.shape[0], v.shape[0])
    cdef Py_ssize_t count = 0, i
    if not _fit_rounds(&p[0], v, x, y, radius_px, rules, work, &count):
        return None
    jtj = np.empty((NP, NP))
    cdef double[:, ::1] out = jtj
    for i in range(NP * NP):
        out[i // NP, i % NP] = work.fit.jtj[i]
    return work.fit.r2, 2 * count, jtj


def refit(Optics optics, const double[:, ::1] v, const double[::1] x, const double[::1] y,
          double radius_px, double sigma_px, RefitRules rules):
    """The whole refit of startrack.verify._refit in one call: :func:`fit_rounds` from
    the camera ``optics`` (its k1; its image centre's direction), then (the spots the
    refitted camera explains, ascending; how far (px) the image centre's direction moved;
    its 1-sigma, the residuals' variance taken as at least ``sigma_px`` squared). None
    when a round pairs fewer than ``rules.min_pairs``."""
    cdef Geometry g = optics.geometry
    cdef double cx0 = (g.width - 1.0) / 2.0, cy0 = (g.height - 1.0) / 2.0
    given = unit_vectors(&g, np.array([cx0]), np.array([cy0]))[0]
    cdef double p[NP]
    p[0], p[1], p[2], p[3], p[4], p[5], p[6] = 0.0, 0.0, 0.0, g.f_px, g.cx, g.cy, g.k1
    cdef _Work work = _Work(x.shape[0], v.shape[0])
    cdef Py_ssize_t count = 0, i
    cdef double variance, shift = 0.0, sigma = 0.0
    if not _fit_rounds(p, v, x, y, radius_px, rules, work, &count):
        return None
    variance = max(work.fit.r2 / max(1, 2 * count - NP), sigma_px * sigma_px)
    _centre_move(p, work.fit.jtj, variance, cx0, cy0, given[0] / given[2], given[1] / given[2],
                 g.f_px, &shift, &sigma)
    count = work.pair_within(p, v, x, y, radius_px, count)
    spots = np.empty(count, np.int64)
    cdef long long[::1] a = spots
    for i in range(count):
        a[i] = work.spot[i]
    return spots, shift, sigma
