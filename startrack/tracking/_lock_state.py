"""The state of a frame sequence: attitude prediction and lock.

:class:`Tracker` predicts each frame's attitude from the attitudes before it (the
per-frame rotation estimated from the last two solved frames, carried over any unsolved
ones) with an uncertainty that grows with the frames since the last solution, solves the
frame by :func:`startrack.tracking._tracked_solve.track` near the prediction, and falls back to
lost-in-space when that fails.

Lock states (the record's ``lock``): ``acquired`` (first solution of the sequence, by
lost-in-space), ``tracking`` (solved by tracking), ``reacquired`` (solved by lost-in-space
after a lock had been held: the lock was lost on this frame or earlier), ``lost`` (not
solved, the frame before was: lock lost here), ``none`` (not solved, no lock before).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable

import numpy as np

from startrack._core.tracking.prediction import Motion, predict_attitude
from startrack.database import StarDatabase
from startrack.match_records import Observation, Solution
from startrack.tracking._tracked_solve import CatalogCone, Prior, TrackConfig, track
from startrack.verify import VerifyConfig

LOCK_STATES = ("acquired", "tracking", "reacquired", "lost", "none")


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
        self.cone = CatalogCone()  # the catalog rows of recent frames, reused while they cover

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
        a, rot_a, sig_a = b, rot_b, sig_b  # one attitude: no rate yet
        if len(self.history) >= 2 and b - self.history[-2][0] <= cfg.max_coast_frames + 1:
            a, rot_a, sig_a = self.history[-2]
        motion = Motion(cfg.unknown_rate_rad, cfg.accel_fraction, cfg.rate_floor_rad)
        matrix, sigma = predict_attitude(rot_a, rot_b, b - a, n, sig_a, sig_b, motion)
        return Prior(matrix, sigma)

    def attempt(self, obs: Observation, database: StarDatabase, verify_config: VerifyConfig,
                method: str) -> Solution | None:
        """The next frame solved by tracking alone, or tried: its Solution, solved or not
        (``identify_ms`` covers the prediction and the attempt), None when there is no
        prediction or too few stars. Nothing is recorded: :meth:`record` the answer."""
        t0 = time.perf_counter()
        prior = self.predict()
        # Counted as identify() counts lost-in-space: the prediction, then matching,
        # verification and the attitude.
        elapsed = (time.perf_counter() - t0) * 1000.0
        if prior is None or len(obs) < 3:
            return None
        solution = track(obs, database, prior, verify_config, self.config, method, self.cone)
        return dataclasses.replace(solution, identify_ms=solution.identify_ms + elapsed)

    def record(self, solution: Solution, obs: Observation, mode: str) -> Solution:
        """Take ``solution`` (``mode``: "tracking" or "lost_in_space") as the answer for
        the next frame: the sequence moves on, and the Solution carries ``mode`` and
        ``lock``."""
        return dataclasses.replace(solution, mode=mode, lock=self._advance(solution, obs, mode))

    def step(self, obs: Observation, database: StarDatabase, verify_config: VerifyConfig,
             lost_in_space: Callable[[Observation], Solution], method: str) -> Solution:
        """Solve the next frame of the sequence: by tracking, else by ``lost_in_space``;
        the Solution carries ``mode`` and ``lock``, and ``identify_ms`` covers the
        tracking attempt and any fallback."""
        tracked = self.attempt(obs, database, verify_config, method)
        if tracked is not None and tracked.solved:
            return self.record(tracked, obs, "tracking")
        solution = lost_in_space(obs)
        spent = 0.0 if tracked is None else tracked.identify_ms
        return self.record(dataclasses.replace(solution, identify_ms=solution.identify_ms
                                               + spent), obs, "lost_in_space")

    def skip(self) -> None:
        """A frame of the sequence that could not be read: time passes, nothing solved."""
        self._advance(None, None, "lost_in_space")

    def _advance(self, solution: Solution | None, obs: Observation | None, mode: str) -> str:
        solved = solution is not None and solution.solved
        if solved:
            lock = ("tracking" if mode == "tracking"
                    else "reacquired" if self.ever_locked else "acquired")
            # A lost-in-space solution starts a new lock: the attitudes before it (before a
            # jump, say) say nothing about the rate now.
            kept = self.history[-1:] if lock == "tracking" else []
            self.history = [*kept, (self.frame, solution.rotation.as_matrix(),
                                    attitude_sigma_rad(solution, obs))]
        else:
            lock = "lost" if self.locked else "none"
        self.locked = solved
        self.ever_locked |= solved
        self.frame += 1
        return lock
