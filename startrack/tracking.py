"""Tracking: solve a frame near a predicted attitude, held to lost-in-space's proof.

A star tracker runs lost-in-space once and then tracks. :class:`Tracker` predicts each
frame's attitude from the attitudes before it (the per-frame rotation estimated from the
last two solved frames, carried over any unsolved ones) with an uncertainty that grows
with the frames since the last solution. :func:`track` projects the catalog stars around
the predicted boresight (one k-d tree cone query), pairs the brightest observed stars with
projected stars inside a window sized from that uncertainty, keeps the pairs that agree on
one image displacement (a vectorised vote, so a false star or a neighbour inside the
window cannot pull the match), and hands three-star hypotheses from them to the shared
:func:`startrack.verify.verify`: the same Wahba fit, the same match radius and the same
binomial false-match bound as every lost-in-space matcher, with evidence only from stars
outside the hypothesis. A tracked attitude is therefore never easier to accept wrongly
than a lost-in-space one. When tracking fails, the frame falls back to lost-in-space.

Lock states (the record's ``lock``): ``acquired`` (first solution of the sequence, by
lost-in-space), ``tracking`` (solved by tracking), ``reacquired`` (solved by lost-in-space
after a lock had been held: the lock was lost on this frame or earlier), ``lost`` (not
solved, the frame before was: lock lost here), ``none`` (not solved, no lock before).
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.spatial.transform import Rotation

from startrack.camera import Camera
from startrack.database import StarDatabase
from startrack.identify import residuals_arcsec
from startrack.types import Hypothesis, MatchDiagnostics, Observation, Solution
from startrack.verify import VerifyConfig, verify

LOCK_STATES = ("acquired", "tracking", "reacquired", "lost", "none")


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
    max_window_px: float = 200.0
    max_stars: int = 16
    max_hypotheses: int = 8


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


def _exp(rotvec: np.ndarray) -> np.ndarray:
    """The rotation matrix of a rotation vector (Rodrigues), without scipy's overhead."""
    angle = float(np.linalg.norm(rotvec))
    if angle < 1e-15:
        return np.eye(3)
    k = rotvec / angle
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + math.sin(angle) * kx + (1.0 - math.cos(angle)) * (kx @ kx)


def _log(matrix: np.ndarray) -> np.ndarray:
    """The rotation vector of a rotation matrix (angles well below pi: frame to frame)."""
    cos = min(1.0, max(-1.0, (float(np.trace(matrix)) - 1.0) / 2.0))
    angle = math.acos(cos)
    axis = np.array([matrix[2, 1] - matrix[1, 2], matrix[0, 2] - matrix[2, 0],
                     matrix[1, 0] - matrix[0, 1]])
    if angle < 1e-7:
        return axis / 2.0
    return axis * (angle / (2.0 * math.sin(angle)))


def _candidates(obs: Observation, database: StarDatabase, prior: Prior, window_px: float,
                max_stars: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Pairs (observed star, catalog row) within the window, and their displacements."""
    cam = obs.camera
    matrix = prior.matrix
    reach = _half_diagonal_rad(cam) * 1.02 + window_px / cam.f_px
    rows = database.cone(matrix[:, 2], reach)
    x, y, front = cam.vector_to_pixel(database.vectors[rows] @ matrix)
    keep = front & cam.in_image(x, y, margin=-window_px)
    rows, x, y = rows[keep], x[keep], y[keep]
    m = min(len(obs), max_stars)
    dx = x[None, :] - obs.x[:m, None]
    dy = y[None, :] - obs.y[:m, None]
    oi, cj = np.nonzero(dx**2 + dy**2 <= window_px**2)
    return oi, rows[cj], dx[oi, cj], dy[oi, cj]


def _consistent(oi: np.ndarray, ci: np.ndarray, dx: np.ndarray, dy: np.ndarray,
                tol_px: float) -> tuple[np.ndarray, np.ndarray]:
    """The pairs that agree on one displacement: the candidate supported by the most
    distinct observed stars, and per observed (and catalog) star the pair nearest it."""
    dd = (dx[:, None] - dx[None, :]) ** 2 + (dy[:, None] - dy[None, :]) ** 2
    close = dd <= tol_px**2
    onehot = np.zeros((len(oi), int(oi.max()) + 1), dtype=np.int64)
    onehot[np.arange(len(oi)), oi] = 1
    votes = np.count_nonzero(close.astype(np.int64) @ onehot, axis=1)
    best = int(np.lexsort((dx**2 + dy**2, -votes))[0])
    sel = np.flatnonzero(close[best])
    order = sel[np.argsort(dd[best, sel], kind="stable")]
    _, first_obs = np.unique(oi[order], return_index=True)
    order = order[np.sort(first_obs)]
    _, first_cat = np.unique(ci[order], return_index=True)
    order = np.sort(order[np.sort(first_cat)])
    by_brightness = order[np.argsort(oi[order], kind="stable")]
    return oi[by_brightness], ci[by_brightness]


def track(obs: Observation, database: StarDatabase, prior: Prior,
          verify_config: VerifyConfig | None = None, config: TrackConfig | None = None,
          method: str = "tracking") -> Solution:
    """Solve ``obs`` near ``prior``; an unsolved Solution (reason ``no_track``) when no
    hypothesis from the window passes the shared verification."""
    verify_config = verify_config or VerifyConfig()
    config = config or TrackConfig()
    diag = MatchDiagnostics()
    t0 = time.perf_counter()
    result = None
    radius_px = verify_config.radius_px(obs)
    window = _window_px(obs, prior, config, radius_px)
    if len(obs) >= 3 and window <= config.max_window_px:
        oi, ci, dx, dy = _candidates(obs, database, prior, window, config.max_stars)
        diag.candidates = len(oi)
        if len(oi) >= 3:
            diag_px = math.hypot(obs.camera.width, obs.camera.height)
            tol = radius_px + config.window_sigma * prior.sigma_rad * diag_px
            o_s, c_s = _consistent(oi, ci, dx, dy, tol)
            result = _first_accepted(o_s, c_s, obs, database, verify_config, config, diag)
    elapsed = (time.perf_counter() - t0) * 1000.0
    if result is None:
        return Solution(False, method, diagnostics=diag, identify_ms=elapsed,
                        reason="no_track" if len(obs) >= 3 else "too_few_stars",
                        mode="tracking")
    order = np.argsort(result.obs_index)
    obs_index, cat_index = result.obs_index[order], result.cat_index[order]
    return Solution(True, method, rotation=result.rotation, obs_index=obs_index,
                    cat_index=cat_index,
                    residual_arcsec=residuals_arcsec(result.rotation, obs, obs_index,
                                                     database.vectors[cat_index]),
                    false_probability=result.false_probability, diagnostics=diag,
                    identify_ms=elapsed, mode="tracking")


def _first_accepted(o_s, c_s, obs, database, verify_config, config, diag):
    """Verify three-star hypotheses from the consistent pairs, brightest first."""
    picks = itertools.islice(itertools.combinations(range(min(len(o_s), 8)), 3),
                             config.max_hypotheses)
    for pick in picks:
        idx = list(pick)
        diag.hypotheses += 1
        check = verify(Hypothesis(o_s[idx], c_s[idx]), obs, database, verify_config)
        if check.accepted:
            return check
    return None


def attitude_sigma_rad(solution: Solution, obs: Observation) -> float:
    """The 1-sigma error of a solved attitude, as an angle seen in the image: the centroid
    error averaged down over the matched stars (doubled, for unmodelled error)."""
    n = max(len(solution.obs_index), 1)
    return 2.0 * obs.sigma_rad / math.sqrt(n)


class Tracker:
    """The state of one frame sequence: its solved attitudes and its lock.

    :meth:`step` solves the next frame: by tracking when a prediction exists, else (or
    when tracking fails) by the ``lost_in_space`` callable it is given. ``initial`` is a
    prior for the first frame; without it the first frame is solved lost-in-space.
    """

    def __init__(self, config: TrackConfig | None = None, initial: Prior | None = None) -> None:
        self.config = config or TrackConfig()
        self.initial = initial  # a prior attitude for the first frame (``--prior``)
        self.reset()

    def reset(self) -> None:
        """Forget the sequence: the next frame is solved lost-in-space."""
        self.frame = 0
        self.history: list[tuple[int, np.ndarray, float]] = []
        self.locked = False
        self.ever_locked = False

    def predict(self, frame: int | None = None) -> Prior | None:
        """The predicted attitude of ``frame`` (default: the next), None when there is no
        recent solution to predict from."""
        k = self.frame if frame is None else frame
        if not self.history:
            return self.initial if k == 0 else None
        b, rot_b, sig_b = self.history[-1]
        n = k - b
        cfg = self.config
        if n > cfg.max_coast_frames + 1:
            return None
        rate, sig_w = np.zeros(3), cfg.unknown_rate_rad
        if len(self.history) >= 2 and b - self.history[-2][0] <= cfg.max_coast_frames + 1:
            a, rot_a, sig_a = self.history[-2]
            # The per-frame rotation in the camera frame: R_b = R_a exp(w (b - a)).
            rate = _log(rot_a.T @ rot_b) / (b - a)
            sig_w = (math.hypot(sig_a, sig_b) / (b - a) + cfg.accel_fraction
                     * float(np.linalg.norm(rate)) + cfg.rate_floor_rad)
        return Prior(rot_b @ _exp(rate * n), sig_b + n * sig_w)

    def step(self, obs: Observation, database: StarDatabase, verify_config: VerifyConfig,
             lost_in_space: Callable[[Observation], Solution], method: str) -> Solution:
        """Solve the next frame of the sequence; the Solution carries ``mode`` and
        ``lock``, and ``identify_ms`` covers the tracking attempt and any fallback."""
        t0 = time.perf_counter()
        prior = self.predict()
        solution = None
        if prior is not None and len(obs) >= 3:
            solution = track(obs, database, prior, verify_config, self.config, method)
        if solution is None or not solution.solved:
            solution = dataclasses.replace(lost_in_space(obs), mode="lost_in_space")
        elapsed = (time.perf_counter() - t0) * 1000.0
        lock = self._advance(solution, obs)
        return dataclasses.replace(solution, identify_ms=elapsed, lock=lock)

    def skip(self) -> None:
        """A frame of the sequence that could not be read: time passes, nothing solved."""
        self._advance(None, None)

    def _advance(self, solution: Solution | None, obs: Observation | None) -> str:
        solved = solution is not None and solution.solved
        if solved:
            lock = ("tracking" if solution.mode == "tracking"
                    else "reacquired" if self.ever_locked else "acquired")
            self.history = [*self.history[-1:], (self.frame, solution.rotation.as_matrix(),
                                                  attitude_sigma_rad(solution, obs))]
        else:
            lock = "lost" if self.locked else "none"
        self.locked = solved
        self.ever_locked |= solved
        self.frame += 1
        return lock
