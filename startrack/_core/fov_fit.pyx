"""The camera fitted to identified stars, compiled (:func:`fit_focal`, called by
:func:`startrack.fov_fit.fit_camera`): the pixels turned into directions through the
current focal length and lens, Wahba's attitude, then the linear least squares of the
focal length (and a fitted k1), until they settle.

The fit runs for every solved frame whose field of view was given as nominal and for
every hypothesis of a blind search, so it must cost microseconds. Each step is the numpy
fit's (``tests/fov_fit_reference.py``) except Wahba's problem (Davenport's q-method, the
same minimiser) and the two-column least squares (Gram-Schmidt instead of an SVD).
"""

cimport cython
from libc.math cimport INFINITY, fabs, isfinite, sqrt

import numpy as np

cimport numpy as cnp

from startrack._core._arrays cimport empty_f64, empty_rows
from startrack._core._camera cimport Geometry, Lens, lens_factor, lens_is_identity, lens_of
from startrack._core._camera cimport lens_undistort
from startrack._core._verify cimport residual_arcsec
from startrack._core._wahba cimport wahba
from startrack._core.camera cimport Optics, unit_vectors

#: What :func:`fit_focal` ended on (its first return value): settled (or out of
#: iterations), a focal length not positive and finite, a fitted k1 folding back inside
#: the image.
SETTLED, BAD_FOCAL, FOLDS = _SETTLED, _BAD_FOCAL, _FOLDS

cnp.import_array()  # the C API the _arrays helpers call


cdef inline double k1_fold_r2(double k1) noexcept nogil:
    """The ideal r^2 where a k1-only lens folds back (inf: never)."""
    return -1.0 / (3.0 * k1) if k1 < 0.0 else INFINITY


cdef bint _folds(const Geometry* g, double f, double k1) noexcept nogil:
    """Whether a k1-only lens folds back inside the image (the refusal of
    :meth:`startrack.camera.Camera.with_distortion`)."""
    cdef double ex = max(fabs(-0.5 - g.cx), fabs(g.width - 0.5 - g.cx))
    cdef double ey = max(fabs(-0.5 - g.cy), fabs(g.height - 0.5 - g.cy))
    cdef double rd2 = (ex * ex + ey * ey) / (f * f)
    cdef Lens lens
    lens.k1, lens.k2, lens.k3 = k1, 0.0, 0.0
    cdef double r2 = k1_fold_r2(k1), s = lens_factor(&lens, r2)
    return isfinite(r2) and rd2 >= r2 * (s * s)


cdef double _dot(const double[::1] a, const double[::1] b) noexcept nogil:
    cdef double t = 0.0
    cdef Py_ssize_t i
    for i in range(a.shape[0]):
        t += a[i] * b[i]
    return t


@cython.cdivision(True)
cdef (double, double) _two_column_lsq(double[::1] a1, double[::1] a2,
                                      const double[::1] d) noexcept nogil:
    """The least-squares (x1, x2) of a1 x1 + a2 x2 = d (the minimum-norm one when the
    columns are parallel), by Gram-Schmidt; a1 and a2 are overwritten."""
    cdef double r11 = sqrt(_dot(a1, a1))
    if r11 == 0.0:
        return 0.0, 0.0
    cdef Py_ssize_t i
    for i in range(a1.shape[0]):
        a1[i] = a1[i] / r11  # q1
    cdef double r12 = _dot(a1, a2)
    for i in range(a2.shape[0]):
        a2[i] = a2[i] - r12 * a1[i]  # w
    cdef double r22 = sqrt(_dot(a2, a2)), b1 = _dot(a1, d), c, x1, x2
    if r22 <= 1e-12 * r11:  # a2 = c a1: x = (1, c) b1 / (r11 (1 + c^2))
        c = r12 / r11
        x1 = b1 / (r11 * (1.0 + c * c))
        return x1, c * x1
    x2 = _dot(a2, d) / r22 / r22
    return (b1 - r12 * x2) / r11, x2


@cython.cdivision(True)
cdef void _directions(const Geometry* g, double f, double k1, const double[::1] dx,
                      const double[::1] dy, double[:, ::1] cam) noexcept nogil:
    """Camera-frame unit vectors of the offsets ``dx``, ``dy`` through focal length ``f``
    and the described lens (else a fitted ``k1``), into ``cam``."""
    cdef Py_ssize_t i, m = dx.shape[0]
    cdef Lens fitted, described = lens_of(g)
    for i in range(m):
        cam[i, 0], cam[i, 1] = dx[i] / f, dy[i] / f
    if not lens_is_identity(&described):
        lens_undistort(&described, &cam[0, 0], &cam[0, 1], m, 3)
    elif k1 != 0.0:
        fitted.k1, fitted.k2, fitted.k3 = k1, 0.0, 0.0
        fitted.max_r2 = k1_fold_r2(k1)
        fitted.r_cap = sqrt(fitted.max_r2)
        lens_undistort(&fitted, &cam[0, 0], &cam[0, 1], m, 3)
    cdef double norm
    for i in range(m):
        norm = sqrt(cam[i, 0] * cam[i, 0] + cam[i, 1] * cam[i, 1] + 1.0)
        cam[i, 0], cam[i, 1], cam[i, 2] = cam[i, 0] / norm, cam[i, 1] / norm, 1.0 / norm


@cython.cdivision(True)
cdef double _tangent(const Geometry* g, const double[:, ::1] cat, const double[:, ::1] rot,
                     double[:, ::1] t) noexcept nogil:
    """The catalog directions in the camera frame (R^T v) on the tangent plane, the lens
    applied when one is described, into ``t`` (x, y, r^2 per star); the largest r^2
    (NaN if any is)."""
    cdef Py_ssize_t i
    cdef double c0, c1, c2, s, top = -INFINITY
    cdef Lens lens = lens_of(g)
    cdef bint described = not lens_is_identity(&lens)
    for i in range(cat.shape[0]):
        c0 = cat[i, 0] * rot[0, 0] + cat[i, 1] * rot[1, 0] + cat[i, 2] * rot[2, 0]
        c1 = cat[i, 0] * rot[0, 1] + cat[i, 1] * rot[1, 1] + cat[i, 2] * rot[2, 1]
        c2 = cat[i, 0] * rot[0, 2] + cat[i, 1] * rot[1, 2] + cat[i, 2] * rot[2, 2]
        t[i, 0], t[i, 1] = c0 / c2, c1 / c2
        if described:  # the lens acts on the normalised plane
            s = lens_factor(&lens, t[i, 0] * t[i, 0] + t[i, 1] * t[i, 1])
            t[i, 0], t[i, 1] = t[i, 0] * s, t[i, 1] * s
        t[i, 2] = t[i, 0] * t[i, 0] + t[i, 1] * t[i, 1]
        if not t[i, 2] <= top:  # numpy's max: a NaN wins
            top = t[i, 2]
    return top


@cython.cdivision(True)
cdef (double, double) _lens_step(const double[:, ::1] t, const double[::1] dx,
                                 const double[::1] dy, double max_k1,
                                 double[:, ::1] cols) noexcept nogil:
    """The focal length and k1 of the two-column least squares, rows interleaved x, y
    per star (as t.ravel()); ``cols`` (3, 2 m) is its working space."""
    cdef Py_ssize_t i, m = dx.shape[0]
    cdef double f, g
    for i in range(m):
        cols[0, 2 * i], cols[0, 2 * i + 1] = t[i, 0], t[i, 1]
        cols[1, 2 * i], cols[1, 2 * i + 1] = t[i, 0] * t[i, 2], t[i, 1] * t[i, 2]
        cols[2, 2 * i], cols[2, 2 * i + 1] = dx[i], dy[i]
    f, g = _two_column_lsq(cols[0], cols[1], cols[2])
    return f, (min(max(g / f, -max_k1), max_k1) if f > 0.0 else 0.0)


@cython.cdivision(True)
cdef bint _focal_step(const double[:, ::1] t, const double[::1] dx, const double[::1] dy,
                      double* f) noexcept nogil:
    """The focal length's least squares, (dx . tx + dy . ty) / sum r^2, into ``f``;
    False (``f`` untouched) when the sum is not positive."""
    cdef double r2_sum = 0.0, fx = 0.0, fy = 0.0
    cdef Py_ssize_t i
    for i in range(dx.shape[0]):
        r2_sum += t[i, 2]
    if not r2_sum > 0.0:
        return False
    for i in range(dx.shape[0]):
        fx += dx[i] * t[i, 0]
    for i in range(dx.shape[0]):
        fy += dy[i] * t[i, 1]
    f[0] = (fx + fy) / r2_sum
    return True


def fit_focal(Optics optics, const double[::1] x, const double[::1] y,
              const double[:, ::1] cat, int iterations, bint with_k1, double min_r2,
              double max_k1):
    """Alternate Wahba's attitude and the focal length's (and k1's) least squares, from
    ``optics``'s focal length, for the pixels ``x``, ``y`` of the catalog directions
    ``cat``, at most ``iterations`` times. A described lens (``optics.lens``) is applied
    as it is; ``with_k1``: fit the k1 of an undescribed one when the stars reach r^2 =
    ``min_r2``, within +-``max_k1``. Returns (SETTLED, BAD_FOCAL or FOLDS; the focal
    length; the fitted k1)."""
    cdef Geometry g = optics.geometry
    cdef double f, k1
    cdef int status = fit_geometry(&g, x, y, cat, iterations, with_k1, min_r2, max_k1,
                                   &f, &k1)
    return status, f, k1


@cython.cdivision(True)
cdef int fit_geometry(const Geometry* g, const double[::1] x, const double[::1] y,
                      const double[:, ::1] cat, int iterations, bint with_k1,
                      double min_r2, double max_k1, double* f_out, double* k1_out):
    """:func:`fit_focal` of the camera ``g`` (C callers: the fitted rounds of
    ``startrack._core.fitted_rounds``): the status, the focal length and k1 into
    ``f_out`` and ``k1_out``."""
    cdef Py_ssize_t i, m = x.shape[0]
    # the buffers of every round, made once (numpy's Python calls would cost more than
    # a round's arithmetic)
    cdef double[::1] dx = empty_f64(m), dy = empty_f64(m)
    for i in range(m):
        dx[i], dy[i] = x[i] - g.cx, y[i] - g.cy
    cdef double[:, ::1] cam = empty_rows(m, 3), t = empty_rows(m, 3), rot = empty_rows(3, 3)
    cdef double[:, ::1] cols = empty_rows(3, 2 * m) if with_k1 else None
    cdef double f = g.f_px, k1 = 0.0, f_new, k1_new, top
    cdef bint done
    cdef int _, status = SETTLED
    for _ in range(iterations):
        _directions(g, f, k1, dx, dy, cam)
        wahba(cam, cat, rot)
        top = _tangent(g, cat, rot, t)
        if with_k1 and top >= min_r2:
            f_new, k1_new = _lens_step(t, dx, dy, max_k1, cols)
        else:
            k1_new = 0.0
            if not _focal_step(t, dx, dy, &f_new):  # no star off the axis: nothing to fit
                break
        done = fabs(f_new - f) <= 1e-10 * fabs(f) and fabs(k1_new - k1) <= 1e-12
        f, k1 = f_new, k1_new
        if not (f > 0.0 and isfinite(f)):
            status = BAD_FOCAL
            break
        if k1 != 0.0 and _folds(g, f, k1):
            status = FOLDS
            break
        if done:
            break
    f_out[0], k1_out[0] = f, k1
    return status


def camera_residuals(Optics optics, const double[::1] x, const double[::1] y,
                     const long long[::1] obs_index, const double[:, ::1] cat):
    """The residuals (arcsec) of the observed stars ``obs_index`` (of pixels ``x``,
    ``y`` through ``optics``) against their catalog vectors ``cat`` at the Wahba
    attitude of those pairs: how well a camera fits the stars matched through another
    (``keep_given``'s test). The same arithmetic as ``pixel_to_vector``, ``wahba`` and
    ``residual_arcsec`` called one after the other, in one call."""
    cdef Py_ssize_t k, m = obs_index.shape[0], n = x.shape[0]
    if y.shape[0] != n or cat.shape[0] != m:
        raise ValueError("camera_residuals: x and y, or obs_index and cat, of unequal lengths")
    for k in range(m):
        if not 0 <= obs_index[k] < n:
            raise IndexError(f"camera_residuals: star {obs_index[k]} of {n}")
    cdef const double[:, ::1] vec = unit_vectors(&optics.geometry, x, y)
    cdef double[:, ::1] matched = empty_rows(m, 3), rot = empty_rows(3, 3)
    for k in range(m):
        matched[k, 0], matched[k, 1], matched[k, 2] = (vec[obs_index[k], 0],
                                                       vec[obs_index[k], 1],
                                                       vec[obs_index[k], 2])
    wahba(matched, cat, rot)
    return np.asarray(residual_arcsec(vec, obs_index, rot, cat))
