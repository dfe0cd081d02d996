"""The camera fitted to identified stars, compiled (:func:`fit_focal`, called by
:func:`startrack.solver._fov_fit.fit_camera`): Wahba's attitude from the pixels at the starting
focal length, then the joint least squares of the pixel residuals over the attitude,
the focal length and (for a lens nobody described) k1 (``fit_lsq.pxi``).

The fit runs for every solved frame whose field of view was given as nominal and for
every hypothesis of a blind search, so it must cost microseconds: a few Gauss-Newton
steps on 4 or 5 parameters. ``tests/solver/test_fov_fit.py`` holds it to scipy's
``least_squares`` of the same residuals.
"""

cimport cython
from libc.math cimport INFINITY, NAN, cos, fabs, isfinite, sin, sqrt

import numpy as np

cimport numpy as cnp

from startrack._core._arrays cimport empty_f64, empty_rows
from startrack._core.camera.lens cimport Geometry, Lens, lens_factor, lens_is_identity, lens_of
from startrack._core.camera.lens cimport lens_undistort
from startrack._core.verify.verification cimport residual_arcsec
from startrack._core._wahba cimport wahba
from startrack._core.camera.optics cimport Optics, unit_vectors

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


cdef void fitted_lens(Geometry* g, double k1) noexcept nogil:
    """``g`` given the k1-only lens of a fit: RadialDistortion(k1=k1), its fold radius."""
    g.k1, g.k2, g.k3, g.max_r2 = k1, 0.0, 0.0, k1_fold_r2(k1)


@cython.cdivision(True)
cdef void _directions(const Geometry* g, double f, const double[::1] dx,
                      const double[::1] dy, double[:, ::1] cam) noexcept nogil:
    """Camera-frame unit vectors of the offsets ``dx``, ``dy`` through focal length ``f``
    and the described lens, into ``cam``."""
    cdef Py_ssize_t i, m = dx.shape[0]
    cdef Lens described = lens_of(g)
    for i in range(m):
        cam[i, 0], cam[i, 1] = dx[i] / f, dy[i] / f
    if not lens_is_identity(&described):
        lens_undistort(&described, &cam[0, 0], &cam[0, 1], m, 3)
    cdef double norm
    for i in range(m):
        norm = sqrt(cam[i, 0] * cam[i, 0] + cam[i, 1] * cam[i, 1] + 1.0)
        cam[i, 0], cam[i, 1], cam[i, 2] = cam[i, 0] / norm, cam[i, 1] / norm, 1.0 / norm


@cython.cdivision(True)
cdef double _largest_r2(const double[:, ::1] cat, const double[:, ::1] rot) noexcept nogil:
    """The largest r^2 of the catalog directions on the camera's tangent plane at
    attitude ``rot`` (NaN if any is)."""
    cdef Py_ssize_t i
    cdef double c0, c1, c2, r2, top = -INFINITY
    for i in range(cat.shape[0]):
        c0 = cat[i, 0] * rot[0, 0] + cat[i, 1] * rot[1, 0] + cat[i, 2] * rot[2, 0]
        c1 = cat[i, 0] * rot[0, 1] + cat[i, 1] * rot[1, 1] + cat[i, 2] * rot[2, 1]
        c2 = cat[i, 0] * rot[0, 2] + cat[i, 1] * rot[1, 2] + cat[i, 2] * rot[2, 2]
        r2 = (c0 * c0 + c1 * c1) / (c2 * c2)
        if not r2 <= top:  # numpy's max: a NaN wins
            top = r2
    return top


include "fit_lsq.pxi"


def fit_focal(Optics optics, const double[::1] x, const double[::1] y,
              const double[:, ::1] cat, int iterations, bint with_k1, double min_r2,
              double max_k1, double k1_chi2):
    """The attitude, focal length (and k1) whose projection of the catalog directions
    ``cat`` best fits the pixels ``x``, ``y`` in least squares, from ``optics``'s focal
    length and the Wahba attitude there, in at most ``iterations`` Gauss-Newton steps.
    A described lens (``optics.lens``) is applied as it is; ``with_k1``: fit the k1 of
    an undescribed one when the stars reach r^2 = ``min_r2``, within +-``max_k1``, kept
    where it lowers the squared residuals by more than ``k1_chi2`` variances. Returns (SETTLED, BAD_FOCAL or FOLDS; the focal
    length; the fitted k1)."""
    cdef Geometry g = optics.geometry
    cdef double f, k1
    cdef int status = fit_geometry(&g, x, y, cat, iterations, with_k1, min_r2, max_k1,
                                   k1_chi2, &f, &k1)
    return status, f, k1


def lsq_costs(Optics optics, const double[::1] x, const double[::1] y,
              const double[:, ::1] cat, const double[:, ::1] rot, double f, double k1,
              int n_params):
    """The squared pixel residuals of the catalog directions ``cat`` at attitude ``rot``,
    focal length ``f`` and (without a described lens) k1 ``k1``, summed twice: by the
    normal equations of ``n_params`` parameters (4, or 5 with k1) and by the cost-only
    sum a fit's later halvings take. A fit's steps depend on the two being one number
    (``tests/camera/test_core_camera.py`` holds them equal to the bit)."""
    cdef Geometry g = optics.geometry
    cdef Lens described = lens_of(&g)
    cdef Py_ssize_t m = x.shape[0]
    if y.shape[0] != m or cat.shape[0] != m or rot.shape[0] != 3 or rot.shape[1] != 3 \
            or n_params not in (4, 5):
        raise ValueError("lsq_costs: x, y and cat of one length, rot 3 x 3, 4 or 5 "
                         "parameters")
    cdef double[::1] dx = empty_f64(m), dy = empty_f64(m)
    _offsets(&g, x, y, dx, dy)
    cdef _Normal normal
    _normal_equations(&described, cat, rot, dx, dy, f, k1, n_params, &normal)
    return normal.cost, _cost(&described, cat, rot, dx, dy, f, k1)


cdef int fit_geometry(const Geometry* g, const double[::1] x, const double[::1] y,
                      const double[:, ::1] cat, int iterations, bint with_k1,
                      double min_r2, double max_k1, double k1_chi2, double* f_out,
                      double* k1_out):
    """:func:`fit_focal` of the camera ``g`` (C callers: the fitted rounds of
    ``startrack._core.solver.fitted_rounds``): the status, the focal length and k1 into
    ``f_out`` and ``k1_out``."""
    cdef Py_ssize_t m = x.shape[0]
    cdef double[::1] dx = empty_f64(m), dy = empty_f64(m)
    _offsets(g, x, y, dx, dy)
    cdef double[:, ::1] cam = empty_rows(m, 3), rot = empty_rows(3, 3)
    cdef double[:, ::1] trial = empty_rows(3, 3), plain = empty_rows(3, 3)
    cdef double f = g.f_px, k1 = 0.0, f_plain = g.f_px, k1_plain = 0.0, cost, cost_plain
    cdef Lens described = lens_of(g)
    cdef int steps
    f_out[0], k1_out[0] = f, 0.0
    if m == 0 or iterations <= 0:
        return SETTLED
    _directions(g, f, dx, dy, cam)
    wahba(cam, cat, rot)  # the attitude the pixels give at the starting focal length
    plain[:, :] = rot
    steps = -1
    if with_k1 and _largest_r2(cat, rot) >= min_r2:
        steps = _least_squares(&described, cat, rot, dx, dy, &f, &k1, 5, iterations, trial,
                               &cost)
        if steps >= 0 and not fabs(k1) <= max_k1:  # held at its bound, the rest refitted
            k1 = max_k1 if k1 > 0.0 else -max_k1
            steps = _least_squares(&described, cat, rot, dx, dy, &f, &k1, 4, iterations,
                                   trial, &cost)
    if steps >= 0:  # a k1 stands only where it lowers the residuals significantly
        if _least_squares(&described, cat, plain, dx, dy, &f_plain, &k1_plain, 4,
                          iterations, trial, &cost_plain) >= 0 \
                and not _k1_significant(cost_plain, cost, 2 * m - 5, k1_chi2):
            f, k1 = f_plain, 0.0
    elif _least_squares(&described, cat, plain, dx, dy, &f_plain, &k1_plain, 4,
                        iterations, trial, &cost_plain) >= 0:
        f, k1 = f_plain, 0.0
    else:  # the stars fix no focal length (none off the axis): it stands
        return SETTLED
    f_out[0], k1_out[0] = f, k1
    if not (f > 0.0 and isfinite(f)):
        return BAD_FOCAL
    if k1 != 0.0 and _folds(g, f, k1):
        return FOLDS
    return SETTLED


cdef inline bint _k1_significant(double cost_plain, double cost_k1, Py_ssize_t dof,
                                 double k1_chi2) noexcept nogil:
    """Whether fitting k1 lowered the squared residuals from ``cost_plain`` to ``cost_k1``
    by more than chance would (``k1_chi2`` times the variance per degree of freedom)."""
    if dof <= 0:
        return False
    return (cost_plain - cost_k1) * dof > k1_chi2 * cost_k1


def squared_residuals(Optics optics, const double[::1] x, const double[::1] y,
                      const long long[::1] obs_index, const long long[::1] rows,
                      const double[:, ::1] catalog):
    """How well a camera fits the stars matched through another (``keep_given``'s
    chi-square): the residuals (arcsec) of the observed stars ``obs_index`` (of pixels
    ``x``, ``y`` through ``optics``) against the catalog rows ``rows`` of ``catalog`` at
    the Wahba attitude of those pairs, squared and summed in order. The same arithmetic
    as ``pixel_to_vector``, ``wahba`` and ``residual_arcsec`` called one after the
    other, in one call."""
    cdef Py_ssize_t k, m = rows.shape[0]
    for k in range(m):
        if not 0 <= rows[k] < catalog.shape[0]:
            raise IndexError(f"squared_residuals: row {rows[k]} of {catalog.shape[0]}")
    cdef double[:, ::1] cat = empty_rows(m, 3)
    for k in range(m):
        cat[k, 0], cat[k, 1], cat[k, 2] = (catalog[rows[k], 0], catalog[rows[k], 1],
                                           catalog[rows[k], 2])
    _check_pairs(x, y, obs_index, cat, "squared_residuals")
    return _sum_squares(_residuals(&optics.geometry, x, y, obs_index, cat))


def fit_against(Optics optics, const double[::1] x, const double[::1] y,
                const long long[::1] obs_index, const double[:, ::1] cat, int iterations,
                bint with_k1, double min_r2, double max_k1, double k1_chi2):
    """The camera ``optics`` fitted to its matched stars ``obs_index`` (of pixels ``x``,
    ``y``; catalog vectors ``cat``), as :func:`fit_focal` fits their pixels, and how well
    each camera fits them: (status, focal length, k1, the given camera's squared
    residuals, the fitted camera's), each as :func:`squared_residuals` sums them through
    that camera; both sums NaN unless SETTLED.
    ``given_stands``' test in one call."""
    _check_pairs(x, y, obs_index, cat, "fit_against")
    cdef Py_ssize_t k, m = obs_index.shape[0]
    cdef double[::1] fx = empty_f64(m), fy = empty_f64(m)
    for k in range(m):
        fx[k], fy[k] = x[obs_index[k]], y[obs_index[k]]
    cdef Geometry g = optics.geometry
    cdef double f, k1
    cdef int status = fit_geometry(&g, fx, fy, cat, iterations, with_k1, min_r2, max_k1,
                                   k1_chi2, &f, &k1)
    if status != SETTLED:
        return status, f, k1, NAN, NAN
    cdef double given_sq = _sum_squares(_residuals(&g, x, y, obs_index, cat))
    g.f_px = f
    if k1 != 0.0:
        fitted_lens(&g, k1)
    return status, f, k1, given_sq, _sum_squares(_residuals(&g, x, y, obs_index, cat))


cdef void _check_pairs(const double[::1] x, const double[::1] y,
                       const long long[::1] obs_index, const double[:, ::1] cat,
                       str caller) except *:
    """Refuse pixels and pairs of unequal lengths or an observed index out of range."""
    cdef Py_ssize_t k, m = obs_index.shape[0], n = x.shape[0]
    if y.shape[0] != n or cat.shape[0] != m:
        raise ValueError(f"{caller}: x and y, or obs_index and cat, of unequal lengths")
    for k in range(m):
        if not 0 <= obs_index[k] < n:
            raise IndexError(f"{caller}: star {obs_index[k]} of {n}")


cdef double[::1] _residuals(const Geometry* g, const double[::1] x, const double[::1] y,
                            const long long[::1] obs_index, const double[:, ::1] cat):
    """The residuals (arcsec) of :func:`squared_residuals` through camera ``g``, its
    pairs already checked."""
    cdef Py_ssize_t k, m = obs_index.shape[0]
    cdef const double[:, ::1] vec = unit_vectors(g, x, y)
    cdef double[:, ::1] matched = empty_rows(m, 3), rot = empty_rows(3, 3)
    for k in range(m):
        matched[k, 0], matched[k, 1], matched[k, 2] = (vec[obs_index[k], 0],
                                                       vec[obs_index[k], 1],
                                                       vec[obs_index[k], 2])
    wahba(matched, cat, rot)
    return residual_arcsec(vec, obs_index, rot, cat)


cdef double _sum_squares(const double[::1] a) noexcept:
    cdef double total = 0.0
    cdef Py_ssize_t k
    for k in range(a.shape[0]):
        total += a[k] * a[k]
    return total
