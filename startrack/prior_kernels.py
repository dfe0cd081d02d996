"""Compiled test of a tracked frame's prediction as its own hypothesis: the frame matched
at the predicted attitude, accepted by verification's binomial false-match bound, then
refined and labelled as verification does (numba; one call per tracked frame).

A lost-in-space hypothesis is built from three of the frame's stars, so its evidence is
the other stars that land within the match radius of a catalog star at its attitude. A
prediction is built from earlier frames alone, so every star of this frame is evidence
for it, each within the match window (the prediction's uncertainty plus the match
radius) of a catalog star. The chance that a frame unrelated to the prediction gives as
many such stars is the same binomial tail, over all the stars and with the window's
area in place of the match radius's. Held to the same bound, the prediction is no
easier to accept wrongly than a three-star hypothesis; when the window is too wide for
the test to have power, :func:`startrack.tracking_kernels.attempt` (a vote, then
three-star hypotheses) takes over.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from startrack.matching import verify_kernels
from startrack.matching.check_kernels import binomial_tail, reported
from startrack.tracking_kernels import (
    S_AREA,
    S_CAPTURE,
    S_CONE_REUSE,
    S_HALF_SIDE,
    S_MAX_FALSE,
    S_MIN_CONFIRMED,
    S_RADIUS,
    S_WINDOW,
    covers,
    near,
    warm_up_args,
)

# Stars of a hypothesis built from the frame itself; a prediction must match at least
# this many more than verification's ``min_confirmed``, as a three-star hypothesis must.
HYPOTHESIS_STARS = 3


@njit(cache=True)
def prior_bound(matched, n_obs, n_in, window, area):
    """The chance that ``n_obs`` stars placed at random give at least ``matched`` stars
    within ``window`` px of one of ``n_in`` catalog stars (``area``: pi over the image's
    area in px^2), as verification's bound is computed for a hypothesis's other stars."""
    return binomial_tail(matched - 1, n_obs, min(1.0, n_in * window * window * area))


@njit(cache=True)
def attempt_at_prior(vectors, mags, rows, cone_matrix, cone_turn, obs_vectors, ox, oy,
                     geometry, prior, sigma, scan, flux, has_flux, label, min_fit):
    """The frame matched at the prediction ``prior`` (1-sigma ``sigma`` rad) within the
    tracking window, the match held to the false-match bound (:func:`prior_bound`), then
    verification's refinement from those pairs and its labelling
    (:func:`~startrack.matching.verify_kernels.refine_and_label`). The arguments are
    :func:`startrack.tracking_kernels.attempt`'s, and so is the turn allowed between the
    prediction and the refined attitude.

    Returns (status: 0 not accepted, 1 accepted, 3 the refined attitude left the allowed
    turn, 4 the rows do not cover it; stars matched in the window; catalog stars in the
    image; bound; observed index (ascending); catalog rows; attitude; when accepted, the
    residuals in arcseconds and scipy's quaternion of the attitude, as verification's
    one-call path gives them)."""
    r = scan[S_RADIUS]
    window = scan[S_WINDOW] * sigma + r
    turn = window / scan[S_HALF_SIDE]
    none, none_f = np.zeros(0, np.int64), np.zeros(0)
    if not covers(cone_matrix, cone_turn, prior, turn, scan[S_CONE_REUSE]):
        return 4, 0, 0, 1.0, none, none, prior, none_f, none_f
    obs_m, pos_m, n_in = verify_kernels.match(vectors, prior, ox, oy, geometry, window)
    matched = obs_m.shape[0]
    if matched < HYPOTHESIS_STARS + scan[S_MIN_CONFIRMED]:
        return 0, matched, n_in, 1.0, none, none, prior, none_f, none_f
    prob = prior_bound(matched, ox.shape[0], n_in, window, scan[S_AREA])
    if prob > scan[S_MAX_FALSE]:
        return 0, matched, n_in, prob, none, none, prior, none_f, none_f
    # No refinement rounds: the labelling's radius test at the fit of every matched pair
    # is refinement's first round, and the attitude reported is refitted to the labels.
    obs_i, pos_i, refined, final = verify_kernels.refine_and_label(
        obs_vectors, ox, oy, vectors, mags, geometry, r, scan[S_CAPTURE], obs_m, pos_m, 0,
        flux, has_flux, label[0], label[1], label[2], label[3], label[4], label[5],
        label[6], label[7], label[8], min_fit)
    turn_trace = 1.0 + 2.0 * math.cos(min(turn, math.pi))
    if not near(refined, prior, turn_trace):
        return 3, matched, n_in, prob, obs_i, rows[pos_i], final, none_f, none_f
    resid, quat = reported(obs_vectors, obs_i, final, vectors[pos_i])
    return 1, matched, n_in, prob, obs_i, rows[pos_i], final, resid, quat


def warm_up() -> None:
    """Compile (or load from numba's cache) the kernel on a tiny input."""
    attempt_at_prior(*warm_up_args())
