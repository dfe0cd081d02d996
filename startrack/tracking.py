"""Tracking: solve a frame near a predicted attitude, held to lost-in-space's proof.

A star tracker runs lost-in-space once and then tracks. :class:`startrack.tracker.Tracker`
predicts each frame's attitude and its uncertainty from the frames before it;
:func:`track` projects the catalog stars around
the predicted boresight (one cone lookup), pairs the brightest observed stars with
projected stars inside a window sized from that uncertainty, keeps the pairs that agree on
one image displacement (a vectorised vote, so a false star or a neighbour inside the
window cannot pull the match), and hands three-star hypotheses from them to the shared
:func:`startrack.verify.verify`: the same Wahba fit, the same match radius and the same
binomial false-match bound as every lost-in-space matcher, with evidence only from stars
outside the hypothesis. A tracked attitude is therefore never easier to accept wrongly
than a lost-in-space one. When tracking fails, the frame falls back to lost-in-space.
"""

from __future__ import annotations

import itertools
import math
import time
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.spatial.transform import Rotation

from startrack.camera import Camera
from startrack.database import StarDatabase
from startrack.identify import residuals_arcsec
from startrack.matching.projector import CAPTURE, CONE_LOOKUP_MARGIN, CONE_MARGIN, CatalogProjector
from startrack.tracking_kernels import consistent_pairs
from startrack.types import Hypothesis, MatchDiagnostics, Observation, Solution
from startrack.verify import VerifyConfig, verify

# The vote looks for the densest spot of displacements within this many match radii: the
# true pairs crowd there while chance pairs spread over the whole window.
VOTE_RADII = 3.0


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


@lru_cache(maxsize=16)
def _half_diagonal_rad(camera: Camera) -> float:
    return math.radians(camera.half_diagonal_deg)


def _window_px(obs: Observation, prior: Prior, config: TrackConfig, radius_px: float) -> float:
    cam = obs.camera
    # Off-axis, an angle spans more pixels: 1 + tan^2 at the farthest corner.
    stretch = 1.0 + math.tan(_half_diagonal_rad(cam)) ** 2
    return config.window_sigma * prior.sigma_rad * cam.f_px * stretch + radius_px


class _Projector(CatalogProjector):
    """The catalog stars around the prediction (verify's projector over fixed rows), and
    the pairs of observed stars with them inside the prediction's window."""

    def pairs(self, matrix: np.ndarray, window_px: float, max_stars: int, vote_px: float,
              keep_px: float) -> tuple[np.ndarray, np.ndarray, int]:
        """Pairs of the brightest observed stars with catalog rows within the window that
        agree on one displacement (:func:`startrack.tracking_kernels.consistent_pairs`):
        (observed index, catalog row, pairs in the window)."""
        m = min(len(self.obs), max_stars)
        oi, pos, n_pairs = consistent_pairs(self.vectors, np.ascontiguousarray(matrix),
                                            self.ox[:m], self.oy[:m], self.geometry,
                                            float(window_px), float(vote_px), float(keep_px))
        return oi, self.rows[pos], int(n_pairs)


def track(obs: Observation, database: StarDatabase, prior: Prior,
          verify_config: VerifyConfig | None = None, config: TrackConfig | None = None,
          method: str = "tracking") -> Solution:
    """Solve ``obs`` near ``prior``; an unsolved Solution (reason ``no_track``) when no
    hypothesis from the window passes verification."""
    verify_config = verify_config or VerifyConfig()
    config = config or TrackConfig()
    diag = MatchDiagnostics()
    t0 = time.perf_counter()
    result = None
    radius_px = verify_config.radius_px(obs)
    window = _window_px(obs, prior, config, radius_px)
    if len(obs) >= 3 and window <= config.max_window_px:
        cam = obs.camera
        reach = (_half_diagonal_rad(cam) * CONE_MARGIN * CONE_LOOKUP_MARGIN
                 + (window + CAPTURE * radius_px) / cam.f_px)
        project = _Projector(obs, database, radius_px, database.cone(prior.matrix[:, 2], reach))
        diag_px = math.hypot(cam.width, cam.height)
        tol = radius_px + config.window_sigma * prior.sigma_rad * diag_px
        o_s, c_s, diag.candidates = project.pairs(prior.matrix, window, config.max_stars,
                                                  min(tol, VOTE_RADII * radius_px), tol)
        if diag.candidates >= 3:
            result = _first_accepted(o_s, c_s, project, verify_config, config, diag)
    # The time of matching, verification and the attitude, as identify() counts it (the
    # Solution's residuals and Rotation are not).
    elapsed = (time.perf_counter() - t0) * 1000.0
    if result is None:
        return Solution(False, method, diagnostics=diag, identify_ms=elapsed,
                        reason="no_track" if len(obs) >= 3 else "too_few_stars",
                        mode="tracking")
    order = np.argsort(result.obs_index)
    obs_index, cat_index = result.obs_index[order], result.cat_index[order]
    residuals = residuals_arcsec(result.matrix, obs, obs_index, database.vectors[cat_index])
    return Solution(True, method, rotation=result.rotation, obs_index=obs_index,
                    cat_index=cat_index, residual_arcsec=residuals,
                    false_probability=result.false_probability, diagnostics=diag,
                    identify_ms=elapsed, mode="tracking")


def _first_accepted(o_s, c_s, project, verify_config, config, diag):
    """Verify three-star hypotheses from the consistent pairs, most consistent first."""
    picks = itertools.islice(itertools.combinations(range(min(len(o_s), 12)), 3),
                             config.max_hypotheses)
    for pick in picks:
        idx = list(pick)
        diag.hypotheses += 1
        check = verify(Hypothesis(o_s[idx], c_s[idx]), project.obs, project.database,
                       verify_config, project)
        if check.accepted:
            return check
    return None
