"""Tracking: solve a frame near a predicted attitude, held to lost-in-space's proof.

A star tracker runs lost-in-space once and then tracks.
:class:`startrack.tracking._lock_state.Tracker` predicts each frame's attitude and its
uncertainty from the frames before it; :func:`track` first tests the prediction itself as
the hypothesis: the frame's stars matched to the catalog stars projected at it within a
window sized from that uncertainty, accepted only when so many matches would come from
an unrelated frame with no more than verification's false-match probability, then
refined and labelled as verification does
(:func:`startrack._core.tracking.tracked_frame.attempt_at_prior`).
Where the window is too wide for that test to have power (after unsolved frames, say), a
vote on the image displacement picks consistent pairs, and three-star hypotheses from
them are tested exactly as :func:`startrack.verify._verification.verify` tests them: the
same Wahba fit, the same match radius and the same binomial bound, with evidence only
from stars outside the hypothesis, then the same labelling
(:func:`startrack._core.tracking.tracked_frame.attempt`). Both run compiled, calling the one
compiled
verification (``startrack/_core/verify/verification.pxd``) itself, over catalog rows that a
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

from startrack._core.tracking.tracked_frame import (
    ACCEPTED,
    UNCOVERED,
    Attempt,
    HeldRows,
    TrackSetup,
    attempt,
    attempt_at_prior,
    consistent_pairs,
    nearby,
)
from startrack.camera import Camera
from startrack.database import StarDatabase
from startrack.match_records import Hypothesis, MatchDiagnostics, Observation, Solution
from startrack.verify import (
    CAPTURE,
    CONE_LOOKUP_MARGIN,
    MAX_REFINEMENTS,
    VerifyConfig,
    cone_radius,
    label_params,
    rotation_of,
)

# The vote looks for the densest spot of displacements within this many match radii: the
# true pairs crowd there while chance pairs spread over the whole window.
VOTE_RADII = 3.0
# Hypotheses are drawn from this many of the most consistent pairs.
HYPOTHESIS_PAIRS = 12
# A hypothesis whose matches miss at most this many of the consistent pairs' stars is
# labelled at their fit at once (startrack._core.tracking.tracked_frame's _settle); else refined
# step by step.
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
    stays inside that (:func:`startrack._core.tracking.tracked_frame.attempt`)."""

    def __init__(self) -> None:
        self.database: StarDatabase | None = None
        self.matrix = np.eye(3)
        self.turn = -1.0
        self.held: HeldRows | None = None  # the rows as the compiled attempts take them
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
                               camera.optics, margin)]
        self.rows = np.ascontiguousarray(rows, dtype=np.int64)
        self.vectors = np.ascontiguousarray(database.vectors[rows])
        self.mags = np.ascontiguousarray(database.catalog.mag[rows], dtype=np.float64)
        self.database, self.matrix, self.turn = database, matrix.copy(), turn
        self.held = HeldRows(self.vectors, self.mags, self.rows, self.matrix, turn)

    def setup(self, obs: Observation, vc: VerifyConfig, config: TrackConfig) -> TrackSetup:
        """What stays from frame to frame of one camera, centroid error and flux
        (:class:`startrack._core.tracking.tracked_frame.TrackSetup`): the camera, verification's own
        thresholds (match radius, capture, refinement rounds, bound, labelling) and the
        tracking window's."""
        key = (obs.camera, obs.sigma_rad, obs.flux is not None, vc, config)
        if key != self._key:
            cam = obs.camera
            radius_px = vc.radius_px(obs)
            check = {"radius_px": radius_px, "cos_radius": math.cos(radius_px / cam.f_px),
                     "cone_radius": 0.0, "margin_cos": -2.0,  # the held rows: no cone
                     "capture": CAPTURE, "max_rounds": MAX_REFINEMENTS,
                     "min_confirmed": vc.min_confirmed,
                     "max_probability": vc.max_false_probability,
                     "max_stars": vc.catalog_stars,
                     "label": label_params(obs, radius_px)}
            # Off-axis, an angle spans more pixels: 1 + tan^2 at the farthest corner.
            stretch = 1.0 + math.tan(math.radians(cam.half_diagonal_deg)) ** 2
            track = {"window_per_sigma": config.window_sigma * cam.f_px * stretch,
                     "keep_per_sigma": config.window_sigma * math.hypot(cam.width,
                                                                        cam.height),
                     "vote_radii": VOTE_RADII, "max_stars": config.max_stars,
                     "max_hypotheses": config.max_hypotheses, "pairs": HYPOTHESIS_PAIRS,
                     "area": math.pi / (cam.width * cam.height),
                     "half_side": 0.5 * min(cam.width, cam.height),
                     "settle_misses": SETTLE_MISSES, "vote_centres": VOTE_CENTRES,
                     "cone_reuse": CONE_REUSE_RAD}
            self._setup = TrackSetup(cam.optics, check, track)
            self._key = key
        return self._setup


@lru_cache(maxsize=64)
def _lens_stretch(camera: Camera, rho_top: float) -> float:
    """Pixels per radian of turn, over f, at most, for stars within ``rho_top`` (tangent of
    the angle off the boresight): a turn moves the tangent-plane point by up to
    (1 + rho^2) per radian and the lens scales that by at most max(|s|, |s + 2 rho^2 s'|)
    (its tangential and radial gains); a star that the lens model cannot place at the
    prediction is kept whatever its position
    (:func:`~startrack._core.tracking.tracked_frame.nearby`).
    Sampled finely, with 1% to spare."""
    d = camera.distortion
    k1, k2, k3, max_r2 = (0.0, 0.0, 0.0, math.inf) if d is None else (d.k1, d.k2, d.k3,
                                                                        d.max_r2)
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
    frame, reused when they cover this one (a :class:`~startrack.tracking._lock_state.Tracker` keeps
    one)."""
    verify_config = verify_config or VerifyConfig()
    config = config or TrackConfig()
    cone = cone or CatalogCone()
    t0 = time.perf_counter()
    found, counts = None, (0, 0)
    setup = cone.setup(obs, verify_config, config)
    window = setup.window_px(prior.sigma_rad)
    if len(obs) >= 3 and window <= config.max_window_px:
        found, counts = _attempt(obs, database, prior, cone, window, setup)
    # The time of matching, verification, the attitude, its quaternion and residuals, as
    # identify() counts lost-in-space's (the compiled attempt computes them; the
    # Solution's Rotation is built from them after the clock stops in both).
    elapsed = (time.perf_counter() - t0) * 1000.0
    diag = MatchDiagnostics(candidates=counts[0], hypotheses=counts[1])
    if found is None:
        return Solution(False, method, diagnostics=diag, identify_ms=elapsed,
                        reason="no_track" if len(obs) >= 3 else "too_few_stars",
                        mode="tracking")
    rotation = rotation_of(found.matrix, found.quaternion)  # as verification builds it
    return Solution(True, method, rotation=rotation, obs_index=found.obs_index,
                    cat_index=found.rows, residual_arcsec=found.residuals,
                    false_probability=float(found.probability), diagnostics=diag,
                    identify_ms=elapsed, mode="tracking")


def track_frame(obs: Observation, setup: TrackSetup):
    """``obs``'s stars as the compiled verification takes them (its ``Frame``)."""
    return setup.frame(np.ascontiguousarray(obs.vectors, dtype=np.float64),
                       np.ascontiguousarray(obs.x, dtype=np.float64),
                       np.ascontiguousarray(obs.y, dtype=np.float64), obs.kernel_flux())


def _attempt(obs: Observation, database: StarDatabase, prior: Prior, cone: CatalogCone,
             window: float, setup: TrackSetup, start: int = 0,
             test_prior: bool = True) -> tuple[Attempt | None, tuple[int, int]]:
    """The compiled attempts: the prediction tested as its own hypothesis
    (:func:`startrack._core.tracking.tracked_frame.attempt_at_prior`), then, when that is not
    accepted,
    the vote and three-star hypotheses (:func:`startrack._core.tracking.tracked_frame.attempt`),
    with the
    held rows looked up again where they do not cover the prediction. Returns (the
    accepted :class:`~startrack._core.tracking.tracked_frame.Attempt` or None, (pairs in the window,
    hypotheses, the prediction counted as one when tested)); ``start``: the first
    three-star hypothesis tried; ``test_prior``: whether the prediction is tested first
    (tests of the three-star attempt alone set it False)."""
    frame = track_frame(obs, setup)
    matrix = np.ascontiguousarray(prior.matrix, dtype=np.float64)
    turn = setup.turn(window)
    looked_up = cone.database is not database
    if looked_up:
        cone.look_up(database, obs.camera, matrix, turn, setup.radius_px)
    tested = int(test_prior)
    while True:
        found = None
        if tested:
            found = attempt_at_prior(cone.held, frame, matrix, prior.sigma_rad, setup)
            if found.status == ACCEPTED:
                return found, (found.pairs, tested)
        if found is None or found.status != UNCOVERED:
            found = attempt(cone.held, frame, matrix, prior.sigma_rad, setup, start)
            if found.status == ACCEPTED:
                return found, (found.pairs, found.tried + tested)
        if found.status == UNCOVERED and not looked_up:  # once: fresh rows cover it
            cone.look_up(database, obs.camera, matrix, turn, setup.radius_px)
            looked_up = True
            continue
        return None, (found.pairs, found.tried + tested)


def hypotheses(obs: Observation, database: StarDatabase, prior: Prior,
               verify_config: VerifyConfig | None = None,
               config: TrackConfig | None = None) -> list[Hypothesis]:
    """The three-star hypotheses :func:`track` tries on ``obs`` near ``prior``, in its
    order (to check its decisions against :func:`startrack.verify._verification.verify`'s)."""
    vc, config, cone = verify_config or VerifyConfig(), config or TrackConfig(), CatalogCone()
    setup = cone.setup(obs, vc, config)
    window = setup.window_px(prior.sigma_rad)
    matrix = np.ascontiguousarray(prior.matrix, dtype=np.float64)
    cone.look_up(database, obs.camera, matrix, setup.turn(window), setup.radius_px)
    m = min(len(obs), config.max_stars)
    oi, cj, _ = consistent_pairs(cone.vectors, matrix, np.ascontiguousarray(obs.x[:m]),
                                 np.ascontiguousarray(obs.y[:m]), prior.sigma_rad, setup)
    picks = itertools.islice(itertools.combinations(range(min(len(oi), HYPOTHESIS_PAIRS)), 3),
                             config.max_hypotheses)
    return [Hypothesis(oi[list(p)], cone.rows[cj[list(p)]]) for p in picks]

