"""Tracking's compiled attempts, each one call per frame: the prediction tested as its own
hypothesis (:func:`attempt_at_prior`), and the vote on the image displacement followed by
three-star hypotheses (:func:`attempt`). Projection, pairing, the first test, the
binomial bound, the refinement and the labelling are the one verification's own
(``verification.pxd``), cimported, so "as verification does" holds by construction.

A prediction is built from earlier frames alone, so every star of the frame is evidence
for it, each within the match window (the prediction's uncertainty plus the match
radius) of a catalog star: held to verification's bound over all the stars, with the
window's area in place of the match radius's, it is no easier to accept wrongly than a
three-star hypothesis.
"""

cimport cython
from libc.math cimport M_PI, cos, isfinite

import numpy as np

cimport numpy as cnp

from startrack._core._arrays cimport zeros_f64, zeros_i64
from startrack._core.verify.nearest cimport Pairs, pairs_within  # the vote's (tracked_vote.pxi)
from startrack._core.verify.verification cimport CheckParams, FirstTest, Frame, Geometry, Labelled
from startrack._core.verify.verification cimport Matches, Projection, Stars, binomial_tail
from startrack._core.verify.verification cimport first_match, match, project, refine_and_label
from startrack._core.verify.verification cimport Verdict, new_frame, report_labelled, within
from startrack._core.camera.optics cimport Optics

cnp.import_array()  # the C API the _arrays helpers call

include "tracked_vote.pxi"

#: What an attempt ended on (:attr:`Attempt.status`).
NONE, ACCEPTED, TURNED, UNCOVERED = 0, 1, 3, 4
# Stars of a hypothesis built from the frame itself; a prediction must match at least
# this many more than verification's ``min_confirmed``, as a three-star hypothesis must.
cdef enum:
    _HYPOTHESIS_STARS = 3
HYPOTHESIS_STARS = _HYPOTHESIS_STARS


cdef struct TrackParams:
    CheckParams check         # verification's own: radius, capture, rounds, bound, labels
    double window_per_sigma   # match window (px) per radian of prediction sigma
    double keep_per_sigma     # the consistent pairs' tolerance (px) per radian of sigma
    double vote_radii         # the vote's radius, in match radii (at most the tolerance)
    Py_ssize_t max_stars      # brightest observed stars paired with the prediction
    Py_ssize_t max_hypotheses # three-star hypotheses tried at most
    Py_ssize_t pairs          # ... drawn from this many of the most consistent pairs
    double area               # pi over the image's area (px^-2): the bound's p per px^2
    double half_side          # half the image's shorter side (px): window -> turn
    Py_ssize_t settle_misses  # consistent pairs unmatched and still labelled at once
    Py_ssize_t vote_centres   # the vote tries the pairs of this many brightest stars
    double cone_reuse         # the held rows' spare turn (rad)


cdef class TrackSetup:
    """What stays from frame to frame of one camera and centroid error: the camera and
    the thresholds (``check``: the fields of verification's ``CheckParams``; ``track``:
    the other fields of ``TrackParams``, as dicts)."""
    cdef TrackParams params
    cdef Geometry geometry

    def __init__(self, Optics optics, dict check, dict track):
        self.geometry = _geometry(optics)
        self.params = dict(track, check=check)

    @property
    def radius_px(self):
        """The match radius (px)."""
        return self.params.check.radius_px

    @property
    def area(self):
        """Pi over the image's area (px^-2): the bound's chance per px^2 of window."""
        return self.params.area

    def window_px(self, double sigma):
        """The match window (px) of a prediction of 1-sigma ``sigma`` rad."""
        return self.params.window_per_sigma * sigma + self.params.check.radius_px

    def keep_px(self, double sigma):
        """The consistent pairs' tolerance (px) at prediction sigma ``sigma`` rad."""
        return self.params.keep_per_sigma * sigma + self.params.check.radius_px

    def turn(self, double window):
        """The turn (rad) that moves a star at the image's edge across ``window`` px."""
        return window / self.params.half_side

    def frame(self, vectors, x, y, flux):
        """The frame's observed stars as verification takes them (:class:`Frame`)."""
        return new_frame(vectors, x, y, flux, &self.geometry)


cdef class HeldRows:
    """The catalog rows held around a recent prediction (their vectors, magnitudes and
    rows as verification's ``Stars``): every star that can reach the image at attitudes
    within ``turn`` rad of ``matrix``."""
    cdef Stars stars
    cdef double[:, ::1] matrix
    cdef double turn

    def __init__(self, vectors, mags, rows, matrix, double turn):
        self.stars = Stars(vectors, mags, rows)
        self.matrix = np.array(matrix, dtype=np.float64)
        self.turn = turn

    @property
    def vectors(self):
        """The held rows' unit vectors (read only)."""
        return np.asarray(self.stars.vectors)


# An attempt's pairs and residuals before it has any: empty, so one array serves them all.
cdef object _NO_ROWS = zeros_i64(0), _NO_RESIDUALS = zeros_f64(0)


cdef class Attempt:
    """What an attempt found: ``status`` (NONE, ACCEPTED, TURNED: the refined attitude
    left the allowed turn, UNCOVERED: the held rows do not cover the allowed turn and
    the caller looks them up again), the hypothesis number accepted (-1), hypotheses
    tried, pairs in the window (or stars matched at the prediction), confirmed stars,
    catalog stars in the image, the bound, the observed index (ascending), the catalog
    rows, the attitude and, once accepted, each star's residual (arcsec) and the
    attitude's quaternion ``[x, y, z, w]``."""
    cdef readonly int status
    cdef readonly Py_ssize_t hypothesis, tried, pairs, confirmed, n_in
    cdef readonly double probability
    cdef readonly object obs_index, rows, matrix, residuals, quaternion

    def __init__(self, int status, prior):
        self.status, self.hypothesis, self.probability = status, -1, 1.0
        self.tried = self.pairs = self.confirmed = self.n_in = 0
        self.obs_index = self.rows = _NO_ROWS
        self.residuals = _NO_RESIDUALS
        self.quaternion = None
        self.matrix = np.asarray(prior)


cdef Geometry _geometry(Optics optics):
    """The camera's geometry as verification's projection takes it."""
    return optics.geometry


cdef bint near(const double[:, :] a, const double[:, :] b, double min_trace) noexcept nogil:
    """Whether attitudes ``a`` and ``b`` differ by at most the angle whose ``1 + 2 cos``
    is ``min_trace`` (the trace of a^T b)."""
    cdef double t = 0.0
    cdef int i, j
    for i in range(3):
        for j in range(3):
            t += a[i, j] * b[i, j]
    return t >= min_trace


cdef bint covers(HeldRows held, const double[:, :] prior, double turn, double reuse):
    """Whether the held rows cover the attitudes within ``turn`` of ``prior`` (rotation
    angles add up), and are not far wider."""
    cdef double spare = held.turn - turn
    return 0.0 <= spare <= 2.0 * reuse and near(held.matrix, prior, 1.0 + 2.0 * cos(spare))


cdef Attempt _labelled(int status, Attempt out, Labelled done, Stars stars, Frame frame):
    """``out`` with the labelled pairs, the rows and the final attitude; once ACCEPTED,
    the residuals and the quaternion (verification's own report of them)."""
    cdef Verdict v = Verdict.__new__(Verdict)
    report_labelled(v, frame, stars, done, status == ACCEPTED)
    out.status, out.obs_index, out.rows, out.matrix = status, v.obs, v.rows, v.final
    if status == ACCEPTED:
        out.residuals, out.quaternion = v.residuals, v.quaternion
    return out


cdef double _prior_bound(Py_ssize_t matched, Py_ssize_t n_obs, Py_ssize_t n_in,
                         double window, double area) noexcept nogil:
    return binomial_tail(matched - 1, n_obs, min(1.0, n_in * window * window * area))


def prior_bound(Py_ssize_t matched, Py_ssize_t n_obs, Py_ssize_t n_in, double window,
                double area):
    """The chance that ``n_obs`` stars placed at random give at least ``matched`` stars
    within ``window`` px of one of ``n_in`` catalog stars (``area``: pi over the image's
    area in px^2), as verification's bound is computed for a hypothesis's other stars."""
    return _prior_bound(matched, n_obs, n_in, window, area)


def attempt_at_prior(HeldRows held, Frame frame, prior_matrix, double sigma,
                     TrackSetup setup):
    """The frame matched at the prediction ``prior_matrix`` (1-sigma ``sigma`` rad)
    within the tracking window, held to the false-match bound over all its stars, then
    verification's labelling at the fit of those pairs (no refinement rounds: the
    labelling's radius test at that fit is refinement's first round) (:class:`Attempt`;
    ``pairs``: the stars matched in the window)."""
    cdef const double[:, ::1] prior = np.ascontiguousarray(prior_matrix, dtype=np.float64)
    cdef TrackParams* p = &setup.params
    cdef double window = setup.window_px(sigma), turn = window / p.half_side
    cdef Attempt out = Attempt(UNCOVERED, prior_matrix)
    if not covers(held, prior, turn, p.cone_reuse):
        return out
    out.status = NONE
    cdef Matches matches = match(frame, held.stars.vectors, prior, window)
    out.pairs, out.n_in = matches.obs.shape[0], matches.n_in
    if out.pairs < _HYPOTHESIS_STARS + p.check.min_confirmed:
        return out
    out.probability = _prior_bound(out.pairs, frame.n, matches.n_in, window, p.area)
    if out.probability > p.check.max_probability:
        return out
    cdef Labelled done = refine_and_label(frame, held.stars, matches, p.check, 0)
    cdef double turn_trace = 1.0 + 2.0 * cos(min(turn, M_PI))
    return _labelled(ACCEPTED if near(done.refined, prior, turn_trace) else TURNED, out,
                     done, held.stars, frame)


cdef Labelled _settle(Frame frame, Stars stars, TrackParams* p, const long long[::1] oi,
                      FirstTest test):
    """An accepted hypothesis refined and labelled. When its attitude already matched the
    observed star of every consistent pair (bar ``settle_misses``), the matches' own fit
    is labelled at once: that is where verification's refinement stops when its first
    refit changes no match. Else its iterative refinement runs."""
    matched = np.zeros(frame.n, np.uint8)
    cdef unsigned char[::1] hit = matched
    cdef Py_ssize_t k, missed = 0
    for k in range(test.matches.obs.shape[0]):
        hit[test.matches.obs[k]] = 1
    for k in range(oi.shape[0]):
        missed += not hit[oi[k]]
    cdef Py_ssize_t rounds = 0 if missed <= p.settle_misses else p.check.max_rounds
    return refine_and_label(frame, stars, test.matches, p.check, rounds)


cdef FirstTest _first_test(Frame frame, Stars stars, Consistent pairs,
                           const long long[::1] triple, TrackParams* p,
                           long long[::1] hyp_obs, double[:, ::1] hyp_sky):
    """Verification's first test of the hypothesis made of the consistent pairs
    ``triple`` (``hyp_obs``, ``hyp_sky``: its buffers)."""
    cdef int k
    for k in range(3):
        hyp_obs[k] = pairs.obs[triple[k]]
        hyp_sky[k, :] = stars.vectors[pairs.pos[triple[k]], :]
    return first_match(frame, hyp_obs, hyp_sky, stars, p.check.radius_px,
                       p.check.cos_radius)


def attempt(HeldRows held, Frame frame, prior_matrix, double sigma, TrackSetup setup,
            Py_ssize_t start=0):
    """The consistent pairs at the prediction (:func:`consistent_pairs`), then their
    three-star hypotheses from number ``start`` on, each through verification's first
    test and its bound; the first accepted is refined and labelled. An attitude turned
    from the prediction by more than the turn that moves a star at the image's edge
    across the window is not taken (:class:`Attempt`)."""
    cdef const double[:, ::1] prior = np.ascontiguousarray(prior_matrix, dtype=np.float64)
    cdef TrackParams* p = &setup.params
    cdef double r = p.check.radius_px, window = setup.window_px(sigma)
    cdef double tol = setup.keep_px(sigma), turn = window / p.half_side
    cdef Attempt out = Attempt(UNCOVERED, prior_matrix)
    if not covers(held, prior, turn, p.cone_reuse):
        return out
    out.status = NONE
    cdef double turn_trace = 1.0 + 2.0 * cos(min(turn, M_PI))
    cdef Py_ssize_t m = min(frame.n, p.max_stars), h
    cdef Consistent pairs = _consistent_pairs(held.stars.vectors, prior, frame.x[:m],
                                              frame.y[:m], setup.geometry, window,
                                              min(tol, p.vote_radii * r), tol,
                                              p.vote_centres)
    out.pairs = pairs.n_pairs
    cdef long long[:, ::1] triples = _triples(min(pairs.obs.shape[0], p.pairs),
                                              p.max_hypotheses)
    cdef long long[::1] hyp_obs = np.empty(3, np.int64)
    cdef double[:, ::1] hyp_sky = np.empty((3, 3))
    cdef FirstTest test
    cdef double prob
    for h in range(start, triples.shape[0]):
        out.tried += 1
        test = _first_test(frame, held.stars, pairs, triples[h], p, hyp_obs, hyp_sky)
        if not test.fits or not near(test.matrix, prior, turn_trace) \
                or test.confirmed < p.check.min_confirmed:
            continue
        prob = binomial_tail(test.confirmed - 1, frame.n - 3,
                             min(1.0, test.matches.n_in * r * r * p.area))
        if prob > p.check.max_probability:
            continue
        out.hypothesis, out.confirmed, out.n_in, out.probability = (
            h, test.confirmed, test.matches.n_in, prob)
        done = _settle(frame, held.stars, p, pairs.obs, test)
        return _labelled(ACCEPTED if near(done.refined, prior, turn_trace) else TURNED,
                         out, done, held.stars, frame)
    return out
