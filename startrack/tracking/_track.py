"""Tracking: solve a frame near a predicted attitude, held to lost-in-space's proof.

A star tracker runs lost-in-space once and then tracks. :class:`startrack.tracking._tracker.Tracker`
predicts each frame's attitude and its uncertainty from the frames before it; :func:`track`
first tests the prediction itself as the hypothesis: the frame's stars matched to the
catalog stars projected at it within a window sized from that uncertainty, accepted only
when so many matches would come from an unrelated frame with no more than verification's
false-match probability, then refined and labelled as verification does
(:mod:`startrack.prior_kernels`). Where the window is too wide for that test to have power
(after unsolved frames, say), a vote on the image displacement picks consistent pairs,
and three-star hypotheses from them are tested exactly as
:func:`startrack.verify._verification.verify`
tests them: the same Wahba fit, the same match radius and the same binomial bound, with
evidence only from stars outside the hypothesis, then the same labelling
(:func:`startrack.tracking_kernels.attempt`). Both run compiled over catalog rows that a
:class:`CatalogCone` keeps from frame to frame. A tracked attitude is therefore never
easier to accept wrongly than a lost-in-space one. When tracking fails, the frame falls
back to lost-in-space.
"""

from __future__ import annotations

import itertools
import math
import time
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.spatial.transform import Rotation

from startrack import prior_kernels
from startrack import tracking_kernels as tk
from startrack.camera._model import Camera
from startrack.database import StarDatabase
from startrack.database.cone import warm_up as warm_up_cone_lookup
from startrack.matching.check_kernels import scipy_quaternion
from startrack.prior_kernels import attempt_at_prior
from startrack.solver._lost_in_space import residuals_arcsec
from startrack.tracking_kernels import attempt, consistent_pairs, nearby
from startrack.types import Hypothesis, MatchDiagnostics, Observation, Solution
from startrack.verify._frame import CAPTURE, CONE_LOOKUP_MARGIN, MAX_REFINEMENTS, cone_radius
from startrack.verify._labelling import kernel_params
from startrack.verify._verification import VerifyConfig, rotation_of

# The vote looks for the densest spot of displacements within this many match radii: the
# true pairs crowd there while chance pairs spread over the whole window.
VOTE_RADII = 3.0
# Hypotheses are drawn from this many of the most consistent pairs.
HYPOTHESIS_PAIRS = 12
# A hypothesis whose matches miss at most this many of the consistent pairs' stars is
# labelled at their fit at once (tracking_kernels._settle); else refined step by step.
SETTLE_MISSES = 0
# The vote tries the pairs of this many of the brightest stars as its centres.
VOTE_CENTRES = 24
# The catalog cone is looked up this much wider than a frame needs and reused while later
# predictions' cones stay inside it: a sequence turns a fraction of a degree per frame.
CONE_REUSE_RAD = math.radians(1.0)


@dataclass(frozen=True)
class TrackConfig:
    """How far a prediction is trusted.

    ``window_sigma``: the match window's half-width in prediction sigmas.
    ``accel_fraction``: unmodelled change of the per-frame rotation, per frame, as a
    fraction of it (angular acceleration, rate-estimate error). ``rate_floor_rad``: a floor
    on that, per frame (jitter). ``unknown_rate_rad``: the prediction sigma per frame when
    only one attitude is known (no rate yet). ``max_coast_frames``: unsolved frames after
    which no prediction is made. ``max_window_px``: a wider window is not tried (the frame
    goes straight to lost-in-space). ``max_stars``: brightest observed stars paired with
    the prediction. ``max_hypotheses``: three-star hypotheses verified at most.
    """

    window_sigma: float = 4.0
    accel_fraction: float = 0.1
    rate_floor_rad: float = math.radians(0.005)
    unknown_rate_rad: float = math.radians(0.25)
    max_coast_frames: int = 10
    max_window_px: float = 500.0
    max_stars: int = 64
    max_hypotheses: int = 24


@dataclass(frozen=True)
class Prior:
    """A predicted attitude (camera to ICRS, a 3 x 3 matrix) and its 1-sigma error angle
    in radians."""

    matrix: np.ndarray
    sigma_rad: float

    @classmethod
    def from_rotation(cls, rotation: Rotation, sigma_rad: float) -> Prior:
        return cls(rotation.as_matrix(), float(sigma_rad))


class CatalogCone:
    """The catalog rows that can reach the image near a recent prediction (their vectors
    and magnitudes with them), reused by later frames while they cover them, and what
    else stays from frame to frame of one camera (:meth:`setup`).

    :meth:`look_up` holds every catalog star that can fall in the image widened by
    ``CAPTURE`` match radii at any attitude within ``turn`` of the prediction: the stars of
    a cone, less those whose projection at the prediction lies too far outside the image
    for such a turn to bring them in. It is looked up for ``CONE_REUSE_RAD`` more turn;
    the attempt kernel keeps it while a later prediction, turned by its own allowance,
    stays inside that (:func:`startrack.tracking_kernels.attempt`)."""

    def __init__(self) -> None:
        self.database: StarDatabase | None = None
        self.matrix = np.eye(3)
        self.turn = -1.0
        self._key: tuple | None = None

    def look_up(self, database: StarDatabase, camera: Camera, matrix: np.ndarray,
                turn: float, radius_px: float) -> None:
        """Hold the rows for attitudes within ``turn`` (radians) of ``matrix``, and then
        some (``CONE_REUSE_RAD``)."""
        turn += CONE_REUSE_RAD
        need = cone_radius(camera) * CONE_LOOKUP_MARGIN + turn + CAPTURE * radius_px / camera.f_px
        rows = database.cone(matrix[:, 2], need)
        if need < math.pi / 2:
            # The stretch is cached per 0.01 of rho, rounded up (a wider range bounds it).
            stretch = _lens_stretch(camera, math.ceil(math.tan(need) * 100.0) / 100.0)
            margin = CAPTURE * radius_px + turn * camera.f_px * stretch + 1.0
            rows = rows[nearby(np.ascontiguousarray(database.vectors[rows]), matrix,
                               camera.geometry, margin)]
        self.rows = rows
        self.vectors = np.ascontiguousarray(database.vectors[rows])
        self.mags = np.ascontiguousarray(database.catalog.mag[rows], dtype=np.float64)
        self.database, self.matrix, self.turn = database, matrix.copy(), turn

    def setup(self, obs: Observation, vc: VerifyConfig, config: TrackConfig) -> tuple:
        """What stays from frame to frame of one camera and centroid error: the match
        radius, the attempt kernel's ``scan``, the labelling's floats and ``min_fit``
        (:func:`startrack.verify._labelling.kernel_params`) and the camera's geometry."""
        key = (obs.camera, obs.sigma_rad, vc, config)
        if key != self._key:
            cam = obs.camera
            radius_px = vc.radius_px(obs)
            label = kernel_params(obs, radius_px)
            half = 0.5 * min(cam.width, cam.height)
            # Off-axis, an angle spans more pixels: 1 + tan^2 at the farthest corner.
            stretch = 1.0 + math.tan(math.radians(cam.half_diagonal_deg)) ** 2
            scan = np.empty(tk.N_SCAN)
            scan[tk.S_WINDOW] = config.window_sigma * cam.f_px * stretch
            scan[tk.S_KEEP] = config.window_sigma * math.hypot(cam.width, cam.height)
            scan[tk.S_VOTE_RADII], scan[tk.S_RADIUS], scan[tk.S_CAPTURE] = (
                VOTE_RADII, radius_px, CAPTURE)
            scan[tk.S_COS_RADIUS] = math.cos(radius_px / cam.f_px)
            scan[tk.S_MAX_STARS], scan[tk.S_ROUNDS] = config.max_stars, MAX_REFINEMENTS
            scan[tk.S_MIN_CONFIRMED] = vc.min_confirmed
            scan[tk.S_MAX_HYPOTHESES], scan[tk.S_PAIRS] = (config.max_hypotheses,
                                                           HYPOTHESIS_PAIRS)
            scan[tk.S_MAX_FALSE] = vc.max_false_probability
            scan[tk.S_AREA] = math.pi / (cam.width * cam.height)
            scan[tk.S_HALF_SIDE], scan[tk.S_SETTLE_MISSES] = half, SETTLE_MISSES
            scan[tk.S_VOTE_CENTRES], scan[tk.S_CONE_REUSE] = VOTE_CENTRES, CONE_REUSE_RAD
            self._setup = (radius_px, scan, np.array(label[2:11], dtype=np.float64),
                           label[11], cam.geometry)
            self._key = key
        return self._setup


@lru_cache(maxsize=64)
def _lens_stretch(camera: Camera, rho_top: float) -> float:
    """Pixels per radian of turn, over f, at most, for stars within ``rho_top`` (tangent of
    the angle off the boresight): a turn moves the tangent-plane point by up to
    (1 + rho^2) per radian and the lens scales that by at most max(|s|, |s + 2 rho^2 s'|)
    (its tangential and radial gains); a star that the lens model cannot place at the
    prediction is kept whatever its position (:func:`~startrack.tracking_kernels.nearby`).
    Sampled finely, with 1% to spare."""
    k1, k2, k3, max_r2 = (float(v) for v in camera.geometry[5:9])
    rho = np.linspace(0.0, min(rho_top, math.sqrt(max_r2)), 4097)
    r2 = rho * rho
    s = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
    ds = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2)
    gain = (1.0 + r2) * np.maximum(np.abs(s), np.abs(s + 2.0 * r2 * ds))
    return 1.01 * float(gain.max())


def track(obs: Observation, database: StarDatabase, prior: Prior,
          verify_config: VerifyConfig | None = None, config: TrackConfig | None = None,
          method: str = "tracking", cone: CatalogCone | None = None) -> Solution:
    """Solve ``obs`` near ``prior``; an unsolved Solution (reason ``no_track``) when no
    hypothesis from the window passes verification. ``cone``: the rows of an earlier
    frame, reused when they cover this one (a :class:`~startrack.tracking._tracker.Tracker` keeps
    one)."""
    verify_config = verify_config or VerifyConfig()
    config = config or TrackConfig()
    cone = cone or CatalogCone()
    t0 = time.perf_counter()
    result, counts = None, (0, 0)
    setup = cone.setup(obs, verify_config, config)
    radius_px, scan = setup[0], setup[1]
    window = scan[tk.S_WINDOW] * prior.sigma_rad + radius_px
    if len(obs) >= 3 and window <= config.max_window_px:
        result, counts = _attempt(obs, database, prior, cone, window, setup)
    if result is not None:
        matrix, obs_index, cat_index, prob, residuals, quat = result
        if residuals is None:  # the three-star attempt: its identities by observed index
            order = np.argsort(obs_index)
            obs_index, cat_index = obs_index[order], cat_index[order]
            residuals = residuals_arcsec(matrix, obs, obs_index, database.vectors[cat_index])
            quat = scipy_quaternion(matrix)
    # The time of matching, verification, the attitude, its quaternion and residuals, as
    # identify() counts lost-in-space's (verification's one-call path computes them; the
    # Solution's Rotation is built from them after the clock stops in both).
    elapsed = (time.perf_counter() - t0) * 1000.0
    diag = MatchDiagnostics(candidates=counts[0], hypotheses=counts[1])
    if result is None:
        return Solution(False, method, diagnostics=diag, identify_ms=elapsed,
                        reason="no_track" if len(obs) >= 3 else "too_few_stars",
                        mode="tracking")
    rotation = rotation_of(matrix, quat)  # as Verification.rotation builds it
    return Solution(True, method, rotation=rotation, obs_index=obs_index, cat_index=cat_index,
                    residual_arcsec=residuals, false_probability=float(prob),
                    diagnostics=diag, identify_ms=elapsed, mode="tracking")


def frame_args(obs: Observation, prior: Prior, setup: tuple) -> tuple:
    """The frame's arguments of the attempt kernels, after the held rows' (``obs``'s
    vectors, x, y, camera geometry, the prior's matrix and sigma, then ``setup``'s scan,
    the flux (x when there is none) and whether there is one, the labelling's floats and
    ``min_fit``), as :func:`startrack.verify._labelling.kernel_params` passes them."""
    radius_px, scan, floats, min_fit, geometry = setup
    has_flux = obs.flux is not None
    return (np.ascontiguousarray(obs.vectors, dtype=np.float64),
            np.ascontiguousarray(obs.x, dtype=np.float64),
            np.ascontiguousarray(obs.y, dtype=np.float64), geometry,
            np.ascontiguousarray(prior.matrix, dtype=np.float64), float(prior.sigma_rad),
            scan, obs.kernel_flux(), has_flux, floats, min_fit)


def _attempt(obs, database, prior, cone, window, setup, start=0, test_prior=True):
    """The compiled attempts: the prediction tested as its own hypothesis
    (:func:`startrack.prior_kernels.attempt_at_prior`), then, when that is not accepted,
    the vote and three-star hypotheses (:func:`startrack.tracking_kernels.attempt`), with
    the held rows looked up again where they do not cover the prediction. Returns
    ((attitude, observed index, catalog rows, bound, residuals, quaternion: the last two
    None from the three-star attempt) or None, (pairs in the window, hypotheses, the
    prediction counted as one when tested)); ``start``: the first
    three-star hypothesis tried; ``test_prior``: whether the prediction is tested first
    (tests of the three-star attempt alone set it False)."""
    radius_px, scan = setup[0], setup[1]
    args = frame_args(obs, prior, setup)
    matrix, turn = args[4], window / scan[tk.S_HALF_SIDE]
    looked_up = cone.database is not database
    if looked_up:
        cone.look_up(database, obs.camera, matrix, turn, radius_px)
    tested = int(test_prior)
    while True:
        held = (cone.vectors, cone.mags, cone.rows, cone.matrix, cone.turn)
        status, n_pairs, tried = 0, 0, 0
        if tested:
            status, n_pairs, _, prob, obs_i, rows, final, resid, quat = attempt_at_prior(
                *held, *args)
            if status == 1:
                return (final, obs_i, rows, prob, resid, quat), (n_pairs, tested)
        if status != 4:
            status, _, tried, n_pairs, _, _, prob, obs_i, rows, final = attempt(
                *held, *args, start)
            if status == 1:
                return (final, obs_i, rows, prob, None, None), (n_pairs, tried + tested)
        if status == 4 and not looked_up:  # once: fresh rows cover it
            cone.look_up(database, obs.camera, matrix, turn, radius_px)
            looked_up = True
            continue
        return None, (n_pairs, tried + tested)


def hypotheses(obs: Observation, database: StarDatabase, prior: Prior,
               verify_config: VerifyConfig | None = None,
               config: TrackConfig | None = None) -> list[Hypothesis]:
    """The three-star hypotheses :func:`track` tries on ``obs`` near ``prior``, in its
    order (to check its decisions against :func:`startrack.verify._verification.verify`'s)."""
    vc, config, cone = verify_config or VerifyConfig(), config or TrackConfig(), CatalogCone()
    radius_px, scan = cone.setup(obs, vc, config)[:2]
    window = scan[tk.S_WINDOW] * prior.sigma_rad + radius_px
    tol = scan[tk.S_KEEP] * prior.sigma_rad + radius_px
    matrix = np.ascontiguousarray(prior.matrix, dtype=np.float64)
    cone.look_up(database, obs.camera, matrix, window / scan[tk.S_HALF_SIDE], radius_px)
    m = min(len(obs), config.max_stars)
    oi, cj, _ = consistent_pairs(cone.vectors, matrix, np.ascontiguousarray(obs.x[:m]),
                                 np.ascontiguousarray(obs.y[:m]), obs.camera.geometry,
                                 window, min(tol, VOTE_RADII * radius_px), tol, VOTE_CENTRES)
    picks = itertools.islice(itertools.combinations(range(min(len(oi), HYPOTHESIS_PAIRS)), 3),
                             config.max_hypotheses)
    return [Hypothesis(oi[list(p)], cone.rows[cj[list(p)]]) for p in picks]


def warm_up() -> None:
    """Compile (or load from numba's cache) every kernel a tracked frame runs, so that the
    first frame of a sequence is not timed with the compilation."""
    tk.warm_up()
    prior_kernels.warm_up()
    warm_up_cone_lookup()  # the held rows' first lookup
