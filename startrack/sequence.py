"""Frame sequences through the pipeline: ``identify --track``, ``--prior`` and the API's
tracking :class:`~startrack.api.Solver`.

:class:`SequenceSolver` solves inputs in order as one sequence with one
:class:`~startrack.tracking.Tracker`; a change of camera or sky starts a new sequence.
:func:`prior_from_radec_roll` turns ``--prior RA,DEC,ROLL`` and its sigma into the
tracking stage's :class:`~startrack.tracking.Prior`, which seeds the first frame.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

from startrack.attitude import from_radec_roll
from startrack.errors import InputError
from startrack.identifier import FrameResult
from startrack.pipeline import FrameInput, Pipeline, read_input
from startrack.tracker import Tracker
from startrack.tracking import Prior, TrackConfig

DEFAULT_PRIOR_SIGMA_DEG = 1.0


def prior_from_radec_roll(ra_deg: float, dec_deg: float, roll_deg: float,
                          sigma_deg: float = DEFAULT_PRIOR_SIGMA_DEG) -> Prior:
    """A prior attitude pointing at (RA, Dec) with ``roll``, 1-sigma ``sigma_deg``."""
    values = (ra_deg, dec_deg, roll_deg, sigma_deg)
    if not all(math.isfinite(v) for v in values):
        raise InputError(f"--prior: values must be finite, got {values}")
    if not -90.0 <= dec_deg <= 90.0:
        raise InputError(f"--prior: Dec must be in [-90, 90], got {dec_deg}")
    if not sigma_deg > 0:
        raise InputError(f"--prior-sigma-deg must be > 0, got {sigma_deg}")
    return Prior.from_rotation(from_radec_roll(ra_deg, dec_deg, roll_deg),
                               math.radians(sigma_deg))


class SequenceSolver:
    """Solve inputs as one sequence (``track=True``) or each alone near ``prior``.

    With ``track`` the first input is solved lost-in-space (or near ``prior``), each later
    one by tracking from the attitudes before it, falling back to lost-in-space; without
    it every input is solved near ``prior`` alone (and falls back the same way).
    """

    def __init__(self, pipeline: Pipeline, *, track: bool = True, prior: Prior | None = None,
                 config: TrackConfig | None = None) -> None:
        self.pipeline, self.track, self.prior, self.config = pipeline, track, prior, config
        self.tracker = Tracker(config, initial=prior)
        self._setup = None

    def reset(self) -> None:
        """Start a new sequence: the next input is solved lost-in-space (or near prior)."""
        self.tracker.reset()

    def skip(self) -> None:
        """An input of the sequence that could not be read: a frame with no solution."""
        if self.track:
            self.tracker.skip()

    def solve(self, frame: FrameInput) -> FrameResult:
        """Solve the next input of the sequence, already read."""
        setup = self.pipeline.setup_for(frame)
        ident = self.pipeline.identifier(*setup)
        if not self.track or setup != self._setup:
            self.tracker.reset()  # a single frame, or another camera: no state carries
        self._setup = setup

        def step(obs):
            solution = self.tracker.step(obs, ident.database, ident.verify_config,
                                         ident.identify, ident.matcher.name)
            return solution if self.track else dataclasses.replace(solution, lock=None)

        return self.pipeline.correct_aberration(frame, ident.solve(frame, identify=step))

    def run(self, path: str | Path) -> FrameResult:
        """Read ``path`` and solve it as the next input of the sequence."""
        return self.solve(read_input(path))
