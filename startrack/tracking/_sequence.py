"""Frame sequences through the pipeline: ``identify --track``, ``--prior`` and the API's
tracking :class:`~startrack.api.Solver`.

:class:`SequenceSolver` solves inputs in order as one sequence with one
:class:`~startrack.tracking._lock_state.Tracker`; a change of camera or sky starts a new
sequence.
:func:`prior_from_radec_roll` turns ``--prior RA,DEC,ROLL`` and its sigma into the
tracking stage's :class:`~startrack.tracking._tracked_solve.Prior`, which seeds the first frame.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path

from startrack.attitude import from_radec_roll
from startrack.camera import Camera
from startrack.database import StarDatabase
from startrack.defaults import DEFAULT_PRIOR_SIGMA_DEG
from startrack.errors import InputError
from startrack.match_records import Solution
from startrack.sky import Catalog, SkySpec
from startrack.solver import (
    FrameInput,
    FrameResult,
    Options,
    Pipeline,
    frame_timing,
    observation,
    read_input,
)
from startrack.tracking._lock_state import Tracker
from startrack.tracking._tracked_solve import Prior, TrackConfig
from startrack.verify import VerifyConfig


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


@dataclass(frozen=True)
class _Held:
    """What a frame is tracked with: the camera of the last lost-in-space solution (the
    fitted one where the field of view was nominal or unknown), the catalog its rows
    index, a database of it for cone lookups, and the method named on tracked frames."""

    camera: Camera
    catalog: Catalog
    database: StarDatabase
    method: str
    #: the camera passed the evidence gate's camera check on the answer that set it (not
    #: so for a camera a prior is first tracked through)
    checked: bool = False


class SequenceSolver:
    """Solve inputs as one sequence (``track=True``) or each alone near ``prior``.

    With ``track`` the first input is solved lost-in-space (or near ``prior``), each later
    one by tracking from the attitudes before it, through the camera that lost-in-space
    established, falling back to lost-in-space; without it every input is solved near
    ``prior`` alone (and falls back the same way). Lost-in-space is the pipeline's own
    (:meth:`startrack.solver._pipeline.Pipeline.identify_frame`): a nominal or unknown field of
    view and a deep narrow-field sky are solved as a single input is.
    """

    def __init__(self, pipeline: Pipeline, *, track: bool = True, prior: Prior | None = None,
                 config: TrackConfig | None = None) -> None:
        self.pipeline, self.track, self.prior, self.config = pipeline, track, prior, config
        self.tracker = Tracker(config, initial=prior)
        self.verify_config = VerifyConfig()
        self._setup = None
        self._held: _Held | None = None

    @property
    def options(self) -> Options:
        """The pipeline's options (:class:`startrack.solver.FrameSolver`)."""
        return self.pipeline.options

    def reset(self) -> None:
        """Start a new sequence: the next input is solved lost-in-space (or near prior)."""
        self.tracker.reset()
        self._held = None

    def skip(self) -> None:
        """An input of the sequence that could not be read: a frame with no solution."""
        if self.track:
            self.tracker.skip()

    def solve(self, frame: FrameInput) -> FrameResult:
        """Solve the next input of the sequence, already read."""
        setup = self.pipeline.setup_for(frame)
        sigma_px = self.pipeline.sigma_px = self.pipeline.frame_sigma(frame)
        if not self.track or setup != self._setup:
            self.reset()  # a single frame, or another camera: no state carries
        self._setup = setup
        held = self._held or self._seeded(*setup)
        spent, failed = 0.0, None
        if held is not None and frame.size in (None, (held.camera.width, held.camera.height)):
            obs = observation(frame.centroids, held.camera, sigma_px)
            tracked = self.tracker.attempt(obs, held.database, self.verify_config, held.method)
            if tracked is not None and tracked.solved:
                solution = self._lock(self.tracker.record(tracked, obs, "tracking"))
                timing = frame_timing(frame, solution.identify_ms)
                return self.pipeline.correct_aberration(frame, FrameResult(
                    frame.name, solution, obs, frame.centroids, timing, held.camera,
                    held.catalog, sigma_px,
                    self.verify_config.radius_px(obs), frame.image), held.checked)
            spent = 0.0 if tracked is None else tracked.identify_ms
            failed = None if tracked is None else (tracked.reason or "no_track")
        found = self.pipeline.identify_frame(frame)
        solution = dataclasses.replace(found.solution,
                                       identify_ms=found.solution.identify_ms + spent,
                                       fallback=failed if found.solution.solved else None)
        solution = self._lock(self.tracker.record(solution, found.obs, "lost_in_space"))
        result = self.pipeline.correct_aberration(frame, dataclasses.replace(
            found, solution=solution, timing=frame_timing(frame, solution.identify_ms)))
        if result.solution.solved:  # held only once the evidence gate passed its camera
            self._held = self._holding(found.camera, found.catalog, solution.method,
                                       checked=True)
        return result

    def run(self, path: str | Path) -> FrameResult:
        """Read ``path`` and solve it as the next input of the sequence."""
        return self.solve(read_input(path, downsample=self.pipeline.options.downsample))

    def _lock(self, solution: Solution) -> Solution:
        return solution if self.track else dataclasses.replace(solution, lock=None)

    def _seeded(self, camera: Camera | None, sky: SkySpec) -> _Held | None:
        """Before any solution, a prior is tracked through the camera as given."""
        if camera is None or self.tracker.predict() is None:
            return None
        return self._holding(camera, self.pipeline.catalog(sky, camera),
                             self.pipeline.options.method)

    def _holding(self, camera: Camera, catalog: Catalog, method: str,
                 checked: bool = False) -> _Held:
        database = (self._held.database if self._held and self._held.catalog is catalog
                    else self.pipeline.database_of(catalog) or StarDatabase(catalog, camera))
        return _Held(camera, catalog, database, method, checked)

