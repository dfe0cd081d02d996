"""The fit-and-verify rounds of a hypothesis at a nominal field of view, in one compiled call
(:class:`FittedRounds`, the rounds of :func:`startrack.solver._fov_fit._verify_fitted`):
verify, fit the camera to the matched stars, turn the pixels into directions through the
fitted camera, verify again, until a round matches the stars of the one before (or, past
REFIT_ROUNDS, its fit barely moved the camera); rounds that never settle give no answer.

Every number a round derives from the focal length
(match radius, the labelling's scales, the catalog cone) is computed here by the same
operations, in the same order, as VerifyConfig.radius_px, label_params, FrameVerifier and
the Camera compute it, so every answer is theirs to the last bit; a change to one of
those formulas must be made here too (``tests/solver/test_fitted_rounds.py`` holds
:meth:`FittedRounds.params_at` to FrameVerifier's thresholds, bit for bit).
"""

cimport cython
from libc.math cimport INFINITY, atan2, cos, fabs, isfinite

import numpy as np

cimport numpy as cnp

from startrack._core._arrays cimport empty_f64, empty_rows
from startrack._core.camera.lens cimport Geometry
from startrack._core.database.cone cimport ConeTable
from startrack._core.verify.verification cimport ACCEPTED, BAD_INDEX, UNLABELLED, CheckParams, Frame
from startrack._core.verify.verification cimport Verdict, check_cone, new_frame
from startrack._core.camera.optics cimport RadialLens, corner_cosines, unit_vectors
from startrack._core.camera.fit cimport _BAD_FOCAL, _FOLDS, fit_geometry, fitted_lens, focal_spread

cnp.import_array()  # the C API the _arrays helpers call


cdef struct FitFrame:
    # One frame's values: principal point and image size (px), the distance to the
    # farthest corner (math.hypot's), the stated centroid noise (px) and VerifyConfig's
    # match radius rule (a fixed radius, else radius_sigma sigmas, at least min_radius).
    double cx
    double cy
    double width
    double height
    double corner_r
    double sigma_px
    bint fixed_radius
    double match_radius
    double radius_sigma
    double min_radius


cdef struct FitConstants:
    # The solver's constants: the labelling's resolve_px and resolve_sigmas; the cone's
    # CONE_MARGIN, CONE_LOOKUP_MARGIN, CONE_REUSE_FRACTION; fit_camera's LENS_MIN_STARS,
    # LENS_MIN_R2, LENS_MAX_K1, LENS_K1_CHI2, FIT_ITERATIONS; REFIT_ROUNDS, SETTLE_ROUNDS,
    # SETTLE_FRACTION; math.radians(1.0) and math.degrees(1.0) (what they multiply by).
    double resolve_px
    double resolve_sigmas
    double cone_margin
    double lookup_margin
    double reuse_fraction
    Py_ssize_t lens_min_stars
    double lens_min_r2
    double lens_max_k1
    double lens_k1_chi2
    int iterations
    int rounds
    int settle_rounds
    double settle_fraction
    double rad
    double deg


cdef class FittedRounds:
    """One frame's fit-and-verify rounds: its pixels ``x``, ``y`` (float64, contiguous),
    its camera's lens (``lens``: the distortion's RadialLens, None for a pinhole; the
    focal length is each call's), its values (``frame``, a FitFrame), the solver's
    ``constants`` (a FitConstants), ``params`` (a CheckParams whose per-camera fields
    are set here) and the catalog (``table``, every star's ``mags``, its ``catalog``
    vectors)."""
    cdef object x_array, y_array, flux_array  # flux_array: None where there are none
    cdef const double[::1] x
    cdef const double[::1] y
    cdef Geometry base
    cdef bint described
    cdef FitFrame values
    cdef FitConstants c
    cdef CheckParams params
    cdef ConeTable table
    cdef object mags_array
    cdef const double[::1] mags
    cdef const double[:, ::1] catalog
    cdef Frame frame  # a run's frame, its bucketed pixels reused by every round
    cdef object vectors  # the vectors of the last round's camera

    def __init__(self, x, y, RadialLens lens, FitFrame frame, FitConstants constants,
                 CheckParams params, ConeTable table, mags, const double[:, ::1] catalog):
        self.x_array, self.y_array, self.flux_array, self.x, self.y = x, y, None, x, y
        if self.x.shape[0] != self.y.shape[0]:
            raise ValueError("FittedRounds: x and y of unequal lengths")
        # Optics.geometry of the camera (its focal length is each call's): the lens's
        # fields, or a pinhole's (RadialLens's defaults)
        self.base.cx, self.base.cy = frame.cx, frame.cy
        self.base.width, self.base.height = frame.width, frame.height
        self.described = lens is not None
        self.base.k1, self.base.k2, self.base.k3, self.base.max_r2 = 0.0, 0.0, 0.0, INFINITY
        if lens is not None:
            self.base.k1, self.base.k2, self.base.k3 = lens.lens.k1, lens.lens.k2, lens.lens.k3
            self.base.max_r2 = lens.lens.max_r2
        self.values, self.c, self.params = frame, constants, params
        self.table, self.mags_array, self.mags, self.catalog = table, mags, mags, catalog
        if self.mags.shape[0] != table.vectors.shape[0]:
            raise ValueError("FittedRounds: one magnitude per catalog star")

    def with_pixels(self, x, y, flux=None):
        """These rounds for another frame's pixels ``x``, ``y`` and fluxes ``flux``
        (float64, contiguous; None where the rounds' labelling weighs none), all else
        shared: a camera, sky and settings make their rounds once, each frame a copy."""
        cdef FittedRounds copy = FittedRounds.__new__(FittedRounds)
        copy.x_array, copy.y_array, copy.flux_array, copy.x, copy.y = x, y, flux, x, y
        if copy.x.shape[0] != copy.y.shape[0] or (flux is not None) != self.params.label.has_flux \
                or (flux is not None and len(flux) != copy.x.shape[0]):
            raise ValueError("FittedRounds: x, y and fluxes of unequal lengths, or fluxes "
                             "that the labelling does not weigh (or none where it does)")
        copy.base, copy.described, copy.values = self.base, self.described, self.values
        copy.c, copy.params = self.c, self.params
        copy.table, copy.mags_array, copy.mags = self.table, self.mags_array, self.mags
        copy.catalog = self.catalog
        return copy

    def pattern_focal(self, const long long[::1] hyp_obs, const long long[::1] hyp_rows,
                      double f):
        """The focal length fitted to the hypothesis' own stars from ``f``, the lens as
        described and no k1 fitted (``fit_focal`` of their pixels and catalog vectors);
        ``f`` itself where that fit is not positive and finite."""
        cdef Py_ssize_t k, m = hyp_obs.shape[0]
        if hyp_rows.shape[0] != m or not (_within(hyp_obs, self.x.shape[0])
                                          and _within(hyp_rows, self.catalog.shape[0])):
            raise IndexError("FittedRounds: a hypothesis' pairs must be as many stars as "
                             "rows, each in range")
        cdef double[::1] fx = empty_f64(m), fy = empty_f64(m)
        cdef double[:, ::1] fcat = empty_rows(m, 3)
        for k in range(m):
            fx[k], fy[k] = self.x[hyp_obs[k]], self.y[hyp_obs[k]]
            fcat[k, 0], fcat[k, 1], fcat[k, 2] = (self.catalog[hyp_rows[k], 0],
                                                  self.catalog[hyp_rows[k], 1],
                                                  self.catalog[hyp_rows[k], 2])
        cdef Geometry g = self.base
        g.f_px = f
        cdef double fitted, k1
        fit_geometry(&g, fx, fy, fcat, self.c.iterations, False, self.c.lens_min_r2,
                     self.c.lens_max_k1, self.c.lens_k1_chi2, &fitted, &k1)
        return fitted if fitted > 0.0 and isfinite(fitted) else f

    def run(self, const long long[::1] hyp_obs, const long long[::1] hyp_rows, double f,
            held_obs=None, held_rows=None, Py_ssize_t held_confirmed=0):
        """The rounds of hypothesis ``hyp_obs`` -> ``hyp_rows`` from the focal length
        ``f``; ``held_obs``, ``held_rows``, ``held_confirmed``: the accepted pairs of the
        first verification when the caller holds it (int64). Returns the accepted
        (Verdict, focal length, fitted k1 (0: none fitted), the observed vectors) of the
        round that matched the stars of the one before, or what ``_verify_fitted``
        returns on failure (the first verification's confirmed count, 0 after a failed
        fit, a later round or rounds that did not settle), or None where the check
        refuses a hypothesis index (the caller reads it as ``verify`` does)."""
        cdef Geometry g = self.base
        g.f_px = f
        cdef bint described = self.described, accepted, usable
        cdef double k1_fitted = 0.0, f_new, k1_new
        cdef Verdict v
        cdef Py_ssize_t confirmed, k, m
        cdef int status, round_
        self.frame = None
        if held_obs is None:
            v = self._check_at(&g, described, hyp_obs, hyp_rows)
            if v.status == BAD_INDEX:
                return None
            accepted, obs, rows, confirmed = v.status == ACCEPTED, v.obs, v.rows, v.confirmed
            usable = accepted or v.status == UNLABELLED
        else:
            accepted, obs, rows, confirmed = True, held_obs, held_rows, held_confirmed
            usable = True
            if not (len(held_obs) == len(held_rows) and _within(held_obs, self.x.shape[0])
                    and _within(held_rows, self.catalog.shape[0])):
                raise IndexError("FittedRounds: a held verification's pairs must be "
                                 "as many stars as rows, each in range")
        cdef const long long[::1] o, r
        cdef double[::1] fx, fy
        cdef double[:, ::1] fcat
        cdef bint settled = False
        cdef double f_before, k1_before
        for round_ in range(self.c.settle_rounds):
            if not usable:  # an unlabelled verdict's matches are fitted all the same
                return confirmed
            o, r = obs, rows
            f_before, k1_before = g.f_px, k1_fitted
            m = o.shape[0]
            fx, fy, fcat = empty_f64(m), empty_f64(m), empty_rows(m, 3)
            for k in range(m):
                fx[k], fy[k] = self.x[o[k]], self.y[o[k]]
                fcat[k, 0], fcat[k, 1], fcat[k, 2] = (self.catalog[r[k], 0],
                                                      self.catalog[r[k], 1],
                                                      self.catalog[r[k], 2])
            status = fit_geometry(&g, fx, fy, fcat, self.c.iterations,
                                  not described and m >= self.c.lens_min_stars,
                                  self.c.lens_min_r2, self.c.lens_max_k1,
                                  self.c.lens_k1_chi2, &f_new, &k1_new)
            if status == _FOLDS:  # Camera.with_distortion's refusal, the same test
                return 0
            g.f_px = f_new  # Camera.with_focal
            if not (status == _BAD_FOCAL or k1_new == 0.0):  # Camera.with_distortion
                fitted_lens(&g, k1_new)
                described, k1_fitted = True, k1_new
            if not (g.f_px > 0.0 and isfinite(g.f_px)):
                return 0
            v = self._check_at(&g, described, hyp_obs, hyp_rows)
            if v.status == BAD_INDEX:
                return None
            accepted, obs, rows = v.status == ACCEPTED, v.obs, v.rows
            usable = accepted or v.status == UNLABELLED
            if accepted and _same(o, obs) and _same(r, rows):
                settled = True
                break  # a fit to the same stars again would return this camera
            # Past REFIT_ROUNDS a round also settles where its fit barely moved the
            # camera (a star at the edge of the radius comes and goes with the noise);
            # a camera fitted to a patch of stars, its scale off and its attitude
            # turned to match, gains stars at the patch's edge round after round.
            if accepted and round_ >= self.c.rounds and _moved_px(
                    f_before, k1_before, g.f_px, k1_fitted, self.values.corner_r,
            ) <= self.c.settle_fraction * self.params.radius_px:
                settled = True
                break
        if not (accepted and settled):  # unsettled: its last matches were never fitted
            return 0
        # Stars in a small patch fix neither the scale nor, turned to match, the
        # attitude: the focal length must be good to a match radius at the corners.
        if not (self.values.sigma_px * focal_spread(&g, fx, fy, fcat) * self.values.corner_r
                <= self.params.radius_px):
            return 0
        return v, g.f_px, k1_fitted, self.vectors

    cdef Verdict _check_at(self, const Geometry* g, bint described,
                           const long long[::1] hyp_obs, const long long[::1] hyp_rows):
        """The hypothesis verified through camera ``g``: the pixels' vectors made through
        it (kept: an accepted verdict's residuals refer to them), the run's frame reused,
        the thresholds of ``g`` set."""
        self.vectors = self._vectors(g)
        self.frame = self._frame(self.frame, self.vectors, g)
        self._set_params(g, described)
        return check_cone(self.frame, hyp_obs, hyp_rows, self.table, self.mags, self.params)

    def params_at(self, double f, double k1=0.0):
        """The thresholds a round checks with through this frame's camera at focal
        length ``f`` (and a fitted ``k1`` on a pinhole): the CheckParams, as a dict,
        that FrameVerifier makes for that camera."""
        cdef Geometry g = self.base
        g.f_px = f
        cdef bint described = self.described
        if k1 != 0.0 and not described:
            fitted_lens(&g, k1)
            described = True
        self._set_params(&g, described)
        return self.params

    cdef object _vectors(self, const Geometry* g):
        """Camera-frame unit vectors of the pixels through camera ``g``."""
        return unit_vectors(g, self.x, self.y)

    cdef Frame _frame(self, Frame frame, vectors, const Geometry* g):
        """The Frame of ``vectors`` through camera ``g``: ``frame``'s bucketed pixels
        reused (they do not depend on the camera), a new Frame the first time."""
        if frame is None:
            return new_frame(vectors, self.x_array, self.y_array,
                             self.x_array if self.flux_array is None else self.flux_array, g)
        frame.vectors, frame.geometry = vectors, g[0]
        return frame

    @cython.cdivision(True)
    cdef void _set_params(self, const Geometry* g, bint described) except *:
        """The CheckParams and LabelParams fields of camera ``g``, as FrameVerifier,
        VerifyConfig.radius_px and label_params compute them."""
        cdef double f = g.f_px, sigma = self.values.sigma_px / f * f  # obs.sigma_rad * f_px
        cdef double radius = self.values.match_radius, scaled, half, cone
        if not self.values.fixed_radius:  # max(radius_sigma * sigma, min_radius)
            scaled = self.values.radius_sigma * sigma
            radius = self.values.min_radius if self.values.min_radius > scaled else scaled
        self.params.radius_px = radius
        self.params.cos_radius = cos(radius / f)
        if not described:  # Camera.half_diagonal_deg of a pinhole
            half = atan2(self.values.corner_r, f) * self.c.deg
        else:  # with a lens, numpy's arccos (the Camera's; it need not be C's acos)
            half = _largest(np.arccos(corner_cosines(g))) * self.c.deg
        cone = half * self.c.rad * self.c.cone_margin
        self.params.cone_radius = cone * self.c.lookup_margin
        self.params.margin_cos = cos(self.c.reuse_fraction * cone)
        self.params.label.radius2 = radius * radius
        self.params.label.sigma0 = sigma
        scaled = self.c.resolve_sigmas * sigma
        if not scaled > self.c.resolve_px:
            scaled = self.c.resolve_px
        self.params.label.resolve2 = scaled * scaled


include "rounds_arrays.pxi"
