# The one verification of a hypothesis (implemented in verification.pyx; Python's entry points
# are in entry_points.pyx): project the catalog stars into the frame, pair them with the observed
# stars, the first test, the binomial bound on a coincidence, the refinement, the final
# labelling, the Wahba refit, the residuals and the quaternion.
#
# How tracking (and the prior) call it, so that "as verification does" holds by
# construction:
#
#     from startrack._core.verify.verification cimport (Frame, Stars, CheckParams, Matches, FirstTest,
#         Labelled, project, within, match, first_match, refine_and_label, binomial_tail,
#         residual_arcsec)
#     from startrack._core._wahba cimport matrix_to_quaternion   # for Rotation.from_quat
#     from startrack._core.verify.nearest cimport Pairs, pairs_within
#
#     frame = Frame(obs_vectors, ox, oy, flux, geometry)    # once per frame
#     stars = Stars(vectors, mags, rows)                    # the rows held around the prior
#     test = first_match(frame, hyp_obs, hyp_sky, stars, radius_px, cos_radius)
#     if test.fits and test.confirmed >= ...:
#         prob = binomial_tail(test.confirmed - 1, frame.n - 3, p)
#         done = refine_and_label(frame, stars, test.matches, params, rounds)
#         # done.obs, stars.rows[done.pos], done.refined, done.final
#
# ``params`` (CheckParams) carries the match radius, the capture, the refinement rounds
# and the labelling's thresholds (LabelParams); tracking fills it from the same
# VerifyConfig verification uses. Every routine takes and returns named fields.

# Geometry: the camera as projection takes it (Camera.vector_to_pixel, then in_image),
# the one camera struct of the compiled core
from startrack._core.camera.lens cimport Geometry
from startrack._core.database.cone cimport ConeTable
from startrack._core.verify.labelling cimport LabelParams
from startrack._core.verify.nearest cimport NearestScratch, PointGrid


cdef struct CheckParams:
    double radius_px        # the match radius (px)
    double cos_radius       # the first test: cos of the hypothesis's fit radius (rad)
    double cone_radius      # radius of the catalog cone looked up around an attitude (rad)
    double margin_cos       # a cone serves while the boresight stays within (cos of the turn)
    double capture          # the refinement's wider capture, in match radii
    Py_ssize_t max_rounds   # refinement rounds at most
    Py_ssize_t min_confirmed  # stars outside the hypothesis that must be confirmed
    double max_probability  # the bound on a coincidental match
    Py_ssize_t max_stars    # the bound counts only the brightest this many catalog stars
                            # in the image (0: all of them)
    LabelParams label       # the final labelling's thresholds


#: What a check found (Verdict.status).
cpdef enum Status:
    BAD_INDEX = 0      # the hypothesis indexes out of range, repeats a star or is short
    REJECTED = 1       # a pair of the hypothesis lies beyond the match radius at its fit
    NOT_ACCEPTED = 2   # too little independent evidence
    ACCEPTED = 3
    UNLABELLED = 4     # the bound passed, but the final labelling kept too few stars to
                       # carry it (a camera off in scale): the matched pairs, to refit


cdef enum:
    # the stars a final labelling must keep for an accepted verdict, beyond those
    # confirmed: the smallest hypothesis's (a triangle), as the evidence gate counts them
    SMALLEST_HYPOTHESIS = 3


cdef class Projection:
    """Catalog stars projected at an attitude: pixel positions (0 where there is none) and
    which have one (in front of the camera, inside the lens model's fold radius)."""
    cdef double[::1] x
    cdef double[::1] y
    cdef unsigned char[::1] valid


cdef class ProjectionBuffer:
    """A projection's reusable arrays (lengths only grow) and the Projection of the
    first values the last call set."""
    cdef double[::1] x
    cdef double[::1] y
    cdef unsigned char[::1] valid
    cdef Projection view


cdef class VerifyScratch:
    """A check's short-lived buffers, kept from one call to the next as NearestScratch
    keeps the matching's (a check would otherwise allocate tens of small arrays): the
    observed and catalog vectors of a Wahba fit, the projected stars a match or the
    labelling selects (positions, pixel positions, magnitudes), the catalog cone's stars,
    two projections. Their lengths only grow;
    a call uses the first rows it needs and copies out whatever it returns."""
    cdef double[:, ::1] cam
    cdef double[:, ::1] sky
    cdef long long[::1] where
    cdef double[::1] x
    cdef double[::1] y
    cdef double[::1] mags
    cdef double[:, ::1] cone_vectors  # the Stars of the catalog cone a check looked up
    cdef double[::1] cone_mags
    cdef ProjectionBuffer kept  # the refinement's last projection, which the labelling reads
    cdef ProjectionBuffer passing  # a projection matched at once and dropped
    cdef long long[::1] wide_nearest  # the last matching's claims at the wider capture
    cdef double[::1] wide_dist2
    cdef Py_ssize_t wide_stars  # how many stars they index (-1: none made)
    cdef Py_ssize_t wide_in


cdef class Frame:
    """One frame's observed stars as verification takes them: unit vectors (n, 3) in the
    camera frame, pixel positions, fluxes (any values when there are none; LabelParams
    says) and the camera."""
    cdef const double[:, ::1] vectors
    cdef const double[::1] x
    cdef const double[::1] y
    cdef const double[::1] flux
    cdef Geometry geometry
    cdef readonly Py_ssize_t n
    cdef NearestScratch scratch  # the matching's buffers: the thread's, reused by every call
    cdef PointGrid grid  # the observed stars bucketed, for every matching of the frame
    cdef VerifyScratch work  # the check's own buffers: the thread's too


cdef class Stars:
    """Catalog stars: unit vectors (m, 3), magnitudes and their catalog rows (ascending)."""
    cdef const double[:, ::1] vectors
    cdef const double[::1] mags
    cdef const long long[::1] rows


cdef class Matches:
    """Observed stars (``obs``, ascending) paired one-to-one with positions ``pos`` of the
    Stars projected, and how many of those fell in the widened image (``n_in``)."""
    cdef long long[::1] obs
    cdef long long[::1] pos
    cdef Py_ssize_t n_in


cdef class FirstTest:
    """A hypothesis's first test: whether each pair fits at the Wahba attitude ``matrix``;
    then the frame matched there and how many matches lie outside the hypothesis."""
    cdef bint fits
    cdef double[:, ::1] matrix
    cdef Matches matches
    cdef Py_ssize_t confirmed


cdef class Labelled:
    """An accepted hypothesis refined and labelled: the reported pairs (observed ``obs``
    ascending, Stars positions ``pos``), the refined attitude and the attitude refitted to
    the labels (the refined one when fewer than three)."""
    cdef long long[::1] obs
    cdef long long[::1] pos
    cdef double[:, ::1] refined
    cdef double[:, ::1] final


cdef class Verdict:
    """One hypothesis checked: the status, the first attitude, the pairs (catalog rows:
    the labelled ones once ACCEPTED, the refinement's matches when UNLABELLED, else the
    first test's), the bound, the
    confirmed count, the final attitude and, once ACCEPTED, the residuals in arcseconds
    and the quaternion ``[x, y, z, w]`` of the final attitude (_wahba's
    matrix_to_quaternion: what ``Rotation.from_quat`` takes); ``cones``: how many catalog
    cones were looked up (a refinement beyond the first cone's margin looks more up)."""
    cdef readonly int status
    cdef readonly object first  # the arrays as Python reads them (numpy, made once)
    cdef readonly object obs
    cdef readonly object rows
    cdef readonly double probability
    cdef readonly Py_ssize_t confirmed
    cdef readonly object final
    cdef readonly object residuals  # None unless ACCEPTED
    cdef readonly object quaternion  # None unless ACCEPTED
    cdef readonly int cones


cdef Frame new_frame(const double[:, ::1] vectors, const double[::1] x, const double[::1] y,
                     const double[::1] flux, const Geometry* geometry)

cdef double binomial_tail(long long k, long long n, double p) noexcept nogil

cdef bint fits_within(const double[:, :] cam, const double[:, :] sky,
                      const double[:, :] matrix, double cos_radius) noexcept nogil

cdef Projection project(const double[:, ::1] vectors, const double[:, :] matrix,
                        Geometry geometry)

cdef unsigned char[::1] within(Projection projection, Geometry geometry, double margin)

cdef Matches match_projected(Frame frame, Projection projection, double radius)

cdef Matches match(Frame frame, const double[:, ::1] vectors, const double[:, :] matrix,
                   double radius)

cdef FirstTest first_match(Frame frame, const long long[::1] hyp_obs,
                           const double[:, :] hyp_sky, Stars stars, double radius,
                           double cos_radius)

cdef Labelled refine_and_label(Frame frame, Stars stars, Matches start, CheckParams params,
                               Py_ssize_t max_rounds)

cdef void report_labelled(Verdict v, Frame frame, Stars stars, Labelled done,
                          bint accepted) except *

cdef double[::1] residual_arcsec(const double[:, ::1] obs_vectors, const long long[::1] obs,
                                 const double[:, :] matrix, const double[:, :] cat_vectors)

cdef Verdict check_fixed(Frame frame, const long long[::1] hyp_obs,
                         const long long[::1] hyp_rows, const double[:, ::1] catalog,
                         Stars stars, CheckParams params)

cdef Verdict check_cone(Frame frame, const long long[::1] hyp_obs,
                        const long long[::1] hyp_rows, ConeTable table,
                        const double[::1] mags, CheckParams params)
