"""The fit-and-verify rounds of a hypothesis at a nominal field of view, in one compiled call
(:class:`FittedRounds`, the rounds of :func:`startrack.solver._fov_fit._verify_fitted`):
verify, fit the camera to the matched stars, turn the pixels into directions through the
fitted camera, verify again, until a round matches the stars of the one before.

In Python each round made an Observation, a FrameVerifier, a verification and a Camera,
costing more than its compiled work. Every number a round derives from the focal length
(match radius, the labelling's scales, the catalog cone) is computed here by the same
operations, in the same order, as VerifyConfig.radius_px, label_params, FrameVerifier and
the Camera compute it, so every answer is theirs to the last bit.
"""

cimport cython
from libc.math cimport INFINITY, atan2, cos, fabs, isfinite, pow, sqrt

import numpy as np

cimport numpy as cnp

from startrack._core._arrays cimport empty_f64, empty_rows
from startrack._core._camera cimport Geometry as Camera, Lens, lens_is_identity, lens_of
from startrack._core._camera cimport lens_undistort
from startrack._core._cone cimport ConeTable
from startrack._core._verify cimport ACCEPTED, BAD_INDEX, CheckParams, Frame, Geometry
from startrack._core._verify cimport Verdict, check_cone
from startrack._core.camera cimport RadialLens
from startrack._core.fov_fit cimport _BAD_FOCAL, fit_geometry

cnp.import_array()  # the C API the _arrays helpers call


cdef struct FitFrame:
    # One frame's values: the camera's principal point and image size (px), the
    # distance from the principal point to the farthest corner (math.hypot's), the stated
    # centroid noise (px) and VerifyConfig's match radius rule (a fixed radius, else
    # radius_sigma sigmas, at least min_radius).
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
    # CONE_MARGIN, CONE_LOOKUP_MARGIN and CONE_REUSE_FRACTION; fit_camera's
    # LENS_MIN_STARS, LENS_MIN_R2, LENS_MAX_K1 and iterations; REFIT_ROUNDS; and
    # math.radians(1.0), math.degrees(1.0) and 2.0 (the exponent of Python's ``x ** 2``,
    # a runtime value so the compiler keeps ``pow``).
    double resolve_px
    double resolve_sigmas
    double cone_margin
    double lookup_margin
    double reuse_fraction
    Py_ssize_t lens_min_stars
    double lens_min_r2
    double lens_max_k1
    int iterations
    int rounds
    double rad
    double deg
    double two


cdef class FittedRounds:
    """One frame's fit-and-verify rounds: its pixels ``x``, ``y`` (float64, contiguous),
    its camera's lens (``lens``: the distortion's RadialLens, None for a pinhole; the
    focal length is each call's), its values (``frame``, a FitFrame), the solver's
    ``constants`` (a FitConstants), ``params`` (a CheckParams whose per-camera fields
    are set here) and the catalog (``table``, every star's ``mags``, its ``catalog``
    vectors)."""
    cdef object x_array, y_array
    cdef const double[::1] x
    cdef const double[::1] y
    cdef Camera base
    cdef bint described
    cdef FitFrame values
    cdef FitConstants c
    cdef CheckParams params
    cdef ConeTable table
    cdef object mags_array
    cdef const double[::1] mags
    cdef const double[:, ::1] catalog

    def __init__(self, x, y, RadialLens lens, FitFrame frame, FitConstants constants,
                 CheckParams params, ConeTable table, mags, const double[:, ::1] catalog):
        self.x_array, self.y_array, self.x, self.y = x, y, x, y
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

    def run(self, const long long[::1] hyp_obs, const long long[::1] hyp_rows, double f,
            held_obs=None, held_rows=None, Py_ssize_t held_confirmed=0):
        """The rounds of hypothesis ``hyp_obs`` -> ``hyp_rows`` from the focal length
        ``f``; ``held_obs``, ``held_rows``, ``held_confirmed``: the accepted pairs of the
        first verification when the caller holds it (int64). Returns the last accepted
        (Verdict, focal length, fitted k1 (0: none fitted), the observed vectors), or what
        ``_verify_fitted`` returns on failure (the first verification's confirmed count,
        0 after a failed fit or a later round), or None where the Python rounds must
        answer (an index to wrap or refuse, as ``verify`` and numpy's indexing do)."""
        cdef Camera g = self.base
        g.f_px = f
        cdef bint described = self.described, accepted
        cdef double k1_fitted = 0.0, f_new, k1_new
        cdef Frame frame = None
        cdef Verdict v
        cdef Py_ssize_t confirmed, k, m
        cdef int status, round_
        vectors = None
        if held_obs is None:
            vectors = self._vectors(&g)
            frame = self._frame(frame, vectors, &g)
            self._set_params(&g, described)
            v = check_cone(frame, hyp_obs, hyp_rows, self.table, self.mags, self.params)
            if v.status == BAD_INDEX:
                return None
            accepted, obs, rows, confirmed = v.status == ACCEPTED, v.obs, v.rows, v.confirmed
        else:
            accepted, obs, rows, confirmed = True, held_obs, held_rows, held_confirmed
            if not (len(held_obs) == len(held_rows) and _within(held_obs, self.x.shape[0])
                    and _within(held_rows, self.catalog.shape[0])):
                return None  # numpy's indexing wraps or refuses them
        cdef const long long[::1] o, r
        cdef double[::1] fx, fy
        cdef double[:, ::1] fcat
        for round_ in range(self.c.rounds):
            if not accepted:
                return confirmed
            o, r = obs, rows
            m = o.shape[0]
            fx, fy, fcat = empty_f64(m), empty_f64(m), empty_rows(m, 3)
            for k in range(m):
                fx[k], fy[k] = self.x[o[k]], self.y[o[k]]
                fcat[k, 0], fcat[k, 1], fcat[k, 2] = (self.catalog[r[k], 0],
                                                      self.catalog[r[k], 1],
                                                      self.catalog[r[k], 2])
            status = fit_geometry(&g, fx, fy, fcat, self.c.iterations,
                                  not described and m >= self.c.lens_min_stars,
                                  self.c.lens_min_r2, self.c.lens_max_k1, &f_new, &k1_new)
            g.f_px = f_new  # Camera.with_focal
            if not (status == _BAD_FOCAL or k1_new == 0.0):  # Camera.with_distortion
                if self._folds(f_new, k1_new):
                    return 0
                g.k1, g.k2, g.k3 = k1_new, 0.0, 0.0
                g.max_r2 = -1.0 / (3.0 * k1_new) if k1_new < 0.0 else INFINITY
                described, k1_fitted = True, k1_new
            if not (g.f_px > 0.0 and isfinite(g.f_px)):
                return 0
            vectors = self._vectors(&g)
            frame = self._frame(frame, vectors, &g)
            self._set_params(&g, described)
            v = check_cone(frame, hyp_obs, hyp_rows, self.table, self.mags, self.params)
            if v.status == BAD_INDEX:
                return None
            accepted, obs, rows = v.status == ACCEPTED, v.obs, v.rows
            if accepted and _same(o, obs) and _same(r, rows):
                break  # a fit to the same stars again would return this camera
        return (v, g.f_px, k1_fitted, vectors) if accepted else 0

    @cython.cdivision(True)
    cdef bint _folds(self, double f, double k1):
        """Whether the k1-only lens folds back inside the image at focal length ``f``, in
        :meth:`startrack.camera.Camera.with_distortion`'s arithmetic (Python's ``x ** 2``
        is ``pow``; ``max`` keeps the first of equals)."""
        cdef double a = fabs(-0.5 - self.base.cx)
        cdef double b = fabs(self.base.width - 0.5 - self.base.cx)
        cdef double ex = b if b > a else a
        a, b = fabs(-0.5 - self.base.cy), fabs(self.base.height - 0.5 - self.base.cy)
        cdef double ey = b if b > a else a
        cdef double rd2 = (pow(ex, self.c.two) + pow(ey, self.c.two)) / pow(f, self.c.two)
        cdef double r2 = -1.0 / (3.0 * k1) if k1 < 0.0 else INFINITY  # RadialDistortion.max_r2
        cdef double factor = 1.0 + r2 * (k1 + r2 * (0.0 + r2 * 0.0))
        return isfinite(r2) and rd2 >= r2 * pow(factor, self.c.two)

    @cython.cdivision(True)
    cdef object _vectors(self, const Camera* g):
        """Camera-frame unit vectors of the pixels (``Optics.pixel_to_vector``)."""
        cdef Py_ssize_t i, n = self.x.shape[0]
        cdef double[::1] a = empty_f64(n), b = empty_f64(n)
        for i in range(n):
            a[i] = (self.x[i] - g.cx) / g.f_px
            b[i] = (self.y[i] - g.cy) / g.f_px
        cdef Lens lens = lens_of(g)
        if n and not lens_is_identity(&lens) and lens_undistort(&lens, &a[0], &b[0], n, 1) < 0:
            raise MemoryError("FittedRounds: no memory for the lens inversion")
        out = empty_rows(n, 3)
        cdef double[:, ::1] vec = out
        cdef double norm
        for i in range(n):
            norm = sqrt(a[i] * a[i] + b[i] * b[i] + 1.0)
            vec[i, 0], vec[i, 1], vec[i, 2] = a[i] / norm, b[i] / norm, 1.0 / norm
        return out

    cdef Frame _frame(self, Frame frame, vectors, const Camera* g):
        """The Frame of ``vectors`` through camera ``g``: ``frame``'s bucketed pixels
        reused (they do not depend on the camera), a new Frame the first time."""
        cdef Geometry geometry
        geometry.f_px, geometry.cx, geometry.cy = g.f_px, g.cx, g.cy
        geometry.width, geometry.height = g.width, g.height
        geometry.k1, geometry.k2, geometry.k3, geometry.max_r2 = g.k1, g.k2, g.k3, g.max_r2
        if frame is None:
            return Frame(vectors, self.x_array, self.y_array, self.x_array, geometry)
        frame.vectors, frame.geometry = vectors, geometry
        return frame

    @cython.cdivision(True)
    cdef void _set_params(self, const Camera* g, bint described) except *:
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
            half = _largest(np.arccos(_corner_cosines(g))) * self.c.deg
        cone = half * self.c.rad * self.c.cone_margin
        self.params.cone_radius = cone * self.c.lookup_margin
        self.params.margin_cos = cos(self.c.reuse_fraction * cone)
        self.params.label.radius2 = pow(radius, self.c.two)
        self.params.label.sigma0 = sigma
        scaled = self.c.resolve_sigmas * sigma
        if not scaled > self.c.resolve_px:
            scaled = self.c.resolve_px
        self.params.label.resolve2 = pow(scaled, self.c.two)


cdef bint _within(const long long[::1] index, Py_ssize_t size) noexcept:
    """Whether every index lies in [0, size)."""
    cdef Py_ssize_t i
    for i in range(index.shape[0]):
        if index[i] < 0 or index[i] >= size:
            return False
    return True


cdef bint _same(const long long[::1] a, const long long[::1] b) noexcept:
    """Whether two index arrays hold the same values (``_same_stars``)."""
    if a.shape[0] != b.shape[0]:
        return False
    cdef Py_ssize_t i
    for i in range(a.shape[0]):
        if a[i] != b[i]:
            return False
    return True


@cython.cdivision(True)
cdef object _corner_cosines(const Camera* g):
    """``Optics.corner_cosines`` of camera ``g``, operation for operation: the cosine of
    the angle from the boresight to each corner pixel's centre."""
    out = empty_f64(4)
    cdef double[::1] u = out
    cdef double v[4]
    u[0], u[1], u[2], u[3] = 0.0, g.width - 1.0, 0.0, g.width - 1.0
    v[0], v[1], v[2], v[3] = 0.0, 0.0, g.height - 1.0, g.height - 1.0
    cdef Py_ssize_t i
    for i in range(4):
        u[i] = (u[i] - g.cx) / g.f_px
        v[i] = (v[i] - g.cy) / g.f_px
    cdef Lens lens = lens_of(g)
    if not lens_is_identity(&lens) and lens_undistort(&lens, &u[0], &v[0], 4, 1) < 0:
        raise MemoryError("FittedRounds: no memory for the lens inversion")
    for i in range(4):
        u[i] = 1.0 / sqrt(u[i] * u[i] + v[i] * v[i] + 1.0)
    return out


cdef double _largest(const double[::1] a):
    """``float(np.maximum.reduce(a))``: the largest value, NaN if any is."""
    cdef double top = a[0]
    cdef Py_ssize_t i
    for i in range(1, a.shape[0]):
        if a[i] != a[i] or a[i] > top:
            top = a[i]
        if top != top:
            break
    return top
