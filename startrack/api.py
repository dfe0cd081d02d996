
"""The Python API of docs/conventions.md: ``startrack.solve(...)`` and ``startrack.Solver``.

A :class:`Solver` loads the catalog and database once and solves frame after frame; each
answer is a :class:`SolveResult` whose ``to_dict()`` is the JSON record that
``startrack identify --format json`` prints.
"""

from __future__ import annotations

import functools
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from startrack._api_checks import api_camera, api_prior, api_size, api_time, check_solver_numbers
from startrack.attitude import to_quaternion, to_radec_roll
from startrack.camera._model import Camera
from startrack.centroids._table import (
    DEFAULT_SIGMA_PX,
    MAX_CENTROID_COORD_PX,
    Centroids,
    bad_centroid_row,
)
from startrack.defaults import DEFAULT_FOV_TOLERANCE, DEFAULT_METHOD
from startrack.errors import InputError, as_builtin
from startrack.outputs._records import frame_record
from startrack.solver._hints import preset, user_hints
from startrack.solver._identifier import FrameResult
from startrack.solver._inputs import FrameInput, image_input, read_input
from startrack.solver._pipeline import Options, Pipeline
from startrack.tracking._sequence import SequenceSolver, prior_from_radec_roll
from startrack.units import degree_options, scale_value
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
        """A tracking Solver's lock state after this frame (startrack.tracking._tracker); else
        None."""
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
    def rotation(self):
        """The attitude as a scipy ``Rotation`` (camera to ICRS); None if not solved."""
        return self.frame.solution.rotation if self.solved else None

    @property
    def boresight(self):
        """The boresight as an astropy ``SkyCoord`` (ICRS); None if not solved."""
        if not self.solved:
            return None
        from astropy.coordinates import SkyCoord  # astropy: only for the astropy views

        return SkyCoord(self.ra_deg, self.dec_deg, unit="deg", frame="icrs")

    @property
    def wcs(self):
        """The solved frame's astropy ``WCS`` (TAN, with SIP terms when they are fitted
        or the camera has lens distortion; ``startrack identify --wcs`` writes the same
        header); None if not solved. Pixels are ours: ``all_pix2world(x, y, 0)``."""
        if not self.solved:
            return None
        from astropy.wcs import WCS, FITSFixedWarning  # astropy: only for the astropy views

        from startrack.outputs._wcs import solved_wcs_header  # astropy: as above

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", FITSFixedWarning)
            return WCS(solved_wcs_header(self.frame))

    @property
    def quality(self) -> dict | None:
        """The record's ``quality`` (docs/conventions.md): residuals, the attitude's
        1-sigma, the false-match probability, the catalog; None if not solved."""
        quality = self.frame.quality
        return None if quality is None else quality.to_dict()

    def __repr__(self) -> str:
        name = "" if self.frame.input == "<array>" else f" {Path(self.frame.input).name}"
        if not self.solved:
            return f"<SolveResult{name}: not solved ({self.reason})>"
        q = self.quality
        return (f"<SolveResult{name}: solved by {self.frame.solution.method}, RA "
                f"{self.ra_deg:.5f} Dec {self.dec_deg:+.5f} roll {self.roll_deg:.3f} deg, "
                f"FOV {self.fov_deg:.3f} deg, {q['n_matched']} stars, rms "
                f"{q['rms_arcsec']:.2f} arcsec>")

    @property
    def stars(self) -> pd.DataFrame:
        """The identified stars: x, y, catalog_id, ra_deg, dec_deg, residual_arcsec."""
        return pd.DataFrame(self.to_dict()["stars"], columns=STAR_COLUMNS)

    def to_dict(self) -> dict:
        """The docs/conventions.md solution record (``input`` is left out for arrays)."""
        return frame_record(self.frame, with_input=self.frame.input != "<array>")


def _builtin_errors(method):
    """``method`` raising the API's errors as built-in subclasses
    (:func:`startrack.errors.as_builtin`)."""
    @functools.wraps(method)
    def wrapper(*args, **kwargs):
        try:
            return method(*args, **kwargs)
        except InputError as exc:
            raised = as_builtin(exc)
            if raised is exc:
                raise
            raise raised from None
    return wrapper


class Solver:
    r"""Loads catalog and database once; :meth:`solve` answers one frame at a time.

    Give the camera as ``fov_deg`` (with ``size=(width, height)`` for centroid arrays;
    images give their own size) or ``camera`` (a :class:`Camera` or a camera file path);
    either is nominal, good to ``fov_tolerance`` (a fraction; 0: exact). With neither, the
    field of view is searched (:data:`startrack.defaults.BLIND_FOV_RANGE`).
    The other keywords are ``startrack identify``'s options (``time``: ISO 8601 text or an
    astropy Time, for the aberration correction).

    Hints (:mod:`startrack.solver._hints`): ``ra``, ``dec``, ``radius`` (the boresight lies within
    ``radius`` of (ra, dec)); ``scale_low``, ``scale_high`` in ``scale_units``
    ("degwidth", "arcsecperpix" or "focalmm" with ``pixel_size_um``) instead of
    ``fov_deg``; ``downsample`` (centroids found on the image binned N x N);
    ``header_hints`` (a FITS input's WCS, DATE-OBS and EXPTIME; default on); ``config``,
    a preset (``configs/*.toml`` or its name) whose camera and sky are the defaults.
    Angles may be astropy Quantities. Errors are :class:`~startrack.errors.InputError`\ s
    that are also ``FileNotFoundError`` (a missing file) or ``ValueError`` (bad values).

    Tracking (``identify --track``): with ``track=True`` the frames given to :meth:`solve`
    are one sequence, in order: the first is solved lost-in-space, each later one by
    tracking from the attitudes before it (falling back to lost-in-space when tracking
    fails); :meth:`reset` starts a new sequence. ``prior=(ra, dec, roll)`` in degrees,
    1-sigma ``prior_sigma_deg`` (``identify --prior``), seeds the first frame of a
    sequence, or every frame without ``track``. ``SolveResult.mode`` says which solved it.
    """

    @_builtin_errors
    def __init__(self, fov_deg: float | None = None, *, camera: Camera | str | Path | None = None,
                 size: tuple[int, int] | None = None, method: str = DEFAULT_METHOD,
                 sky: str | None = None, mag_limit: float | None = None,
                 epoch: float | None = None, sigma_px: float = DEFAULT_SIGMA_PX,
                 max_stars: int | None = None, timeout_ms: float | None = None,
                 track: bool = False, prior: tuple[float, float, float] | None = None,
                 prior_sigma_deg: float = 1.0, time: str | None = None,
                 fov_tolerance: float = DEFAULT_FOV_TOLERANCE, ra=None, dec=None,
                 radius=None, scale_low=None, scale_high=None, scale_units: str = "degwidth",
                 pixel_size_um: float | None = None, downsample: int = 1,
                 header_hints: bool = True, config: str | Path | None = None) -> None:
        deg = degree_options(dict(fov_deg=fov_deg, prior=prior, ra=ra, dec=dec,
                                  radius=radius, prior_sigma_deg=prior_sigma_deg))
        fov_deg, prior, prior_sigma_deg = deg["fov_deg"], deg["prior"], deg["prior_sigma_deg"]
        check_solver_numbers(fov_deg=fov_deg, fov_tolerance=fov_tolerance, sigma_px=sigma_px,
                             mag_limit=mag_limit, epoch=epoch, max_stars=max_stars,
                             timeout_ms=timeout_ms, prior_sigma_deg=prior_sigma_deg)
        time, size, prior = api_time(time), api_size(size), api_prior(prior)
        scale_low, scale_units = scale_value(scale_low, scale_units, "scale_low")
        scale_high, scale_units = scale_value(scale_high, scale_units, "scale_high")
        hints = user_hints(deg["ra"], deg["dec"], deg["radius"], scale_low, scale_high,
                           scale_units, pixel_size_um,
                           fov_given=fov_deg is not None or camera is not None)
        camera, sky_spec = preset(config, camera, fov_deg, hints)
        camera = api_camera(camera)
        self._pipeline = Pipeline(Options(method=method, camera=camera, fov_deg=fov_deg,
                                          size=size, sky=sky, mag_limit=mag_limit,
                                          epoch=epoch, max_stars=max_stars, sigma_px=sigma_px,
                                          timeout_ms=timeout_ms, time=time,
                                          fov_tolerance=fov_tolerance, hints=hints,
                                          header_hints=bool(header_hints),
                                          downsample=downsample, sky_spec=sky_spec))
        self._sequence = None
        if track or prior is not None:
            seed = None if prior is None else prior_from_radec_roll(*prior, prior_sigma_deg)
            self._sequence = SequenceSolver(self._pipeline, track=track, prior=seed)

    def reset(self) -> None:
        """Start a new sequence (``track=True``): the next frame is solved lost-in-space."""
        if self._sequence is not None:
            self._sequence.reset()

    @_builtin_errors
    def solve(self, source: str | Path | np.ndarray) -> SolveResult:
        """Solve a path (image or centroid CSV), a 2-D image array, or an N x 2 / N x 3
        array of centroids (x, y[, flux]; brightest first when there is no flux)."""
        try:
            frame = _as_input(source, self._pipeline.options.downsample)
        except InputError:
            if self._sequence is not None:
                self._sequence.skip()  # an unreadable frame of a sequence: time passes
            raise
        solver = self._sequence or self._pipeline
        return SolveResult(solver.solve(frame))


def solve(source: str | Path | np.ndarray, **options) -> SolveResult:
    """Solve one frame; ``options`` are :class:`Solver`'s keywords."""
    return Solver(**options).solve(source)


def _as_input(source: str | Path | np.ndarray, downsample: int = 1) -> FrameInput:
    if isinstance(source, str | Path):
        return read_input(source, downsample=downsample)
    array = np.asarray(source)
    if array.dtype.kind not in "uif":
        raise NumberTypeError(f"cannot solve an array of dtype {array.dtype}: give real numbers "
                        "(a complex image's phase is not light)")
    # Two or three columns are centroids whatever the dtype: no star can be found in an
    # image two or three pixels wide (docs/conventions.md).
    if array.ndim == 2 and array.shape[1] in (2, 3):
        array = array.astype(np.float64)
        bad = bad_centroid_row(array)
        if bad is not None:
            raise InputError(f"<array>: row {bad}: x, y and flux must be finite numbers, x "
                             f"and y within {MAX_CENTROID_COORD_PX:g} px")
        if array.shape[1] == 3:
            return FrameInput("<array>", Centroids(array[:, 0], array[:, 1], array[:, 2]))
        ranks = np.arange(len(array), 0, -1.0)  # listed brightest first
        return FrameInput("<array>", Centroids(array[:, 0], array[:, 1], ranks,
                                               photometric=False))
    if array.ndim == 2:
        return image_input(array, "<array>", downsample=downsample)
    raise InputError(f"cannot solve an array of shape {array.shape}: give a 2-D image or "
                     "an N x 2 / N x 3 array of centroids")
