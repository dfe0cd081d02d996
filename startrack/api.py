"""The Python API of docs/conventions.md: ``startrack.solve(...)`` and ``startrack.Solver``.

A :class:`Solver` loads the catalog and database once and solves frame after frame; each
answer is a :class:`SolveResult` whose ``to_dict()`` is the JSON record that
``startrack identify --format json`` prints.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from startrack.api_checks import api_camera, api_prior, api_size, api_time, check_solver_numbers
from startrack.attitude import to_quaternion, to_radec_roll
from startrack.camera import Camera
from startrack.centroids import DEFAULT_SIGMA_PX, Centroids
from startrack.errors import InputError
from startrack.fov import DEFAULT_FOV_TOLERANCE
from startrack.frame_input import FrameInput, image_input, read_input
from startrack.identifier import FrameResult
from startrack.pipeline import DEFAULT_METHOD, Options, Pipeline
from startrack.validate import NumberTypeError

STAR_COLUMNS = ["x", "y", "catalog_id", "ra_deg", "dec_deg", "residual_arcsec"]


@dataclass(frozen=True)
class SolveResult:
    """One frame's answer. ``catalog_id`` is the HIP number for Hipparcos, the source id
    for a deeper catalog and the 0-based index for a random sky."""

    frame: FrameResult

    @property
    def solved(self) -> bool:
        return self.frame.solution.solved

    @property
    def reason(self) -> str | None:
        """Why the frame is not solved ("too_few_stars", "no_match", ...); None if solved."""
        return None if self.solved else (self.frame.solution.reason or "no_match")

    @property
    def mode(self) -> str | None:
        """How it was solved: "lost_in_space" or "tracking"; None if not solved."""
        return self.frame.solution.mode if self.solved else None

    @property
    def lock(self) -> str | None:
        """A tracking Solver's lock state after this frame (startrack.tracker); else None."""
        return self.frame.solution.lock

    @property
    def quaternion(self) -> np.ndarray | None:
        """Camera-to-ICRS attitude, scalar first [w, x, y, z]."""
        rot = self.frame.solution.rotation
        return None if rot is None or not self.solved else to_quaternion(rot)

    def _radec_roll(self) -> tuple[float, float, float] | tuple[None, None, None]:
        rot = self.frame.solution.rotation
        return (None, None, None) if rot is None or not self.solved else to_radec_roll(rot)

    @property
    def ra_deg(self) -> float | None:
        return self._radec_roll()[0]

    @property
    def dec_deg(self) -> float | None:
        return self._radec_roll()[1]

    @property
    def roll_deg(self) -> float | None:
        return self._radec_roll()[2]

    @property
    def fov_deg(self) -> float | None:
        """The horizontal field of view of the camera the frame was solved with."""
        return self.frame.camera.fov_deg if self.solved else None

    @property
    def stars(self) -> pd.DataFrame:
        """The identified stars: x, y, catalog_id, ra_deg, dec_deg, residual_arcsec."""
        return pd.DataFrame(self.to_dict()["stars"], columns=STAR_COLUMNS)

    def to_dict(self) -> dict:
        """The interfaces.md solution record (``input`` is left out for arrays)."""
        return self.frame.record(with_input=self.frame.input != "<array>")


class Solver:
    """Loads catalog and database once; :meth:`solve` answers one frame at a time.

    Give the camera as ``fov_deg`` (with ``size=(width, height)`` for centroid arrays;
    images give their own size) or ``camera`` (a :class:`Camera` or a camera file path);
    either is nominal, good to ``fov_tolerance`` (a fraction; 0: exact). With neither, the
    field of view is searched (:data:`startrack.fov.BLIND_FOV_RANGE`).
    The other keywords are ``startrack identify``'s options (``time``: ISO 8601 text or an
    astropy Time, for the aberration correction).

    Tracking (``identify --track``): with ``track=True`` the frames given to :meth:`solve`
    are one sequence, in order: the first is solved lost-in-space, each later one by
    tracking from the attitudes before it (falling back to lost-in-space when tracking
    fails); :meth:`reset` starts a new sequence. ``prior=(ra, dec, roll)`` in degrees,
    1-sigma ``prior_sigma_deg`` (``identify --prior``), seeds the first frame of a
    sequence, or every frame without ``track``. ``SolveResult.mode`` says which solved it.
    """

    def __init__(self, fov_deg: float | None = None, *, camera: Camera | str | Path | None = None,
                 size: tuple[int, int] | None = None, method: str = DEFAULT_METHOD,
                 sky: str | None = None, mag_limit: float | None = None,
                 epoch: float | None = None, sigma_px: float = DEFAULT_SIGMA_PX,
                 max_stars: int | None = None, timeout_ms: float | None = None,
                 track: bool = False, prior: tuple[float, float, float] | None = None,
                 prior_sigma_deg: float = 1.0, time: str | None = None,
                 fov_tolerance: float = DEFAULT_FOV_TOLERANCE) -> None:
        check_solver_numbers(fov_deg=fov_deg, fov_tolerance=fov_tolerance, sigma_px=sigma_px,
                             mag_limit=mag_limit, epoch=epoch, max_stars=max_stars,
                             timeout_ms=timeout_ms, prior_sigma_deg=prior_sigma_deg)
        time, camera = api_time(time), api_camera(camera)
        size, prior = api_size(size), api_prior(prior)
        self._pipeline = Pipeline(Options(method=method, camera=camera, fov_deg=fov_deg,
                                          size=size, sky=sky, mag_limit=mag_limit,
                                          epoch=epoch, max_stars=max_stars, sigma_px=sigma_px,
                                          timeout_ms=timeout_ms, time=time,
                                          fov_tolerance=fov_tolerance))
        self._sequence = None
        if track or prior is not None:
            from startrack.sequence import SequenceSolver, prior_from_radec_roll

            seed = None if prior is None else prior_from_radec_roll(*prior, prior_sigma_deg)
            self._sequence = SequenceSolver(self._pipeline, track=track, prior=seed)

    def reset(self) -> None:
        """Start a new sequence (``track=True``): the next frame is solved lost-in-space."""
        if self._sequence is not None:
            self._sequence.reset()

    def solve(self, source: str | Path | np.ndarray) -> SolveResult:
        """Solve a path (image or centroid CSV), a 2-D image array, or an N x 2 / N x 3
        array of centroids (x, y[, flux]; brightest first when there is no flux)."""
        try:
            frame = _as_input(source)
        except InputError:
            if self._sequence is not None:
                self._sequence.skip()  # an unreadable frame of a sequence: time passes
            raise
        solver = self._sequence or self._pipeline
        return SolveResult(solver.solve(frame))


def solve(source: str | Path | np.ndarray, **options) -> SolveResult:
    """Solve one frame; ``options`` are :class:`Solver`'s keywords."""
    return Solver(**options).solve(source)


def _as_input(source: str | Path | np.ndarray) -> FrameInput:
    if isinstance(source, str | Path):
        return read_input(source)
    array = np.asarray(source)
    if array.dtype.kind not in "uif":
        raise NumberTypeError(f"cannot solve an array of dtype {array.dtype}: give real numbers "
                        "(a complex image's phase is not light)")
    # Two or three columns are centroids whatever the dtype: no star can be found in an
    # image two or three pixels wide (docs/conventions.md).
    if array.ndim == 2 and array.shape[1] in (2, 3):
        array = array.astype(np.float64)
        if array.shape[1] == 3:
            return FrameInput("<array>", Centroids(array[:, 0], array[:, 1], array[:, 2]))
        ranks = np.arange(len(array), 0, -1.0)  # listed brightest first
        return FrameInput("<array>", Centroids(array[:, 0], array[:, 1], ranks,
                                               photometric=False))
    if array.ndim == 2:
        return image_input(array, "<array>")
    raise InputError(f"cannot solve an array of shape {array.shape}: give a 2-D image or "
                     "an N x 2 / N x 3 array of centroids")
