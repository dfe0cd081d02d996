"""The answer to one frame through the Python API: :class:`SolveResult`, the attitude, the
identified stars and the JSON record that ``startrack identify --format json`` prints."""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from startrack.attitude import to_quaternion, to_radec_roll
from startrack.outputs import frame_record
from startrack.solver import FrameResult

__all__ = ["STAR_COLUMNS", "SolveResult"]

STAR_COLUMNS = ["x", "y", "catalog_id", "ra_deg", "dec_deg", "residual_arcsec"]


@dataclass(frozen=True)
class SolveResult:
    """One frame's answer, as :meth:`Solver.solve` and :func:`startrack.solve` return it.

    Every property reads the pipeline's record of the frame; an unsolved frame gives None
    for the attitude and an empty star table, and says why in :attr:`reason`.

    Parameters
    ----------
    frame : startrack.solver.FrameResult
        The pipeline's complete answer for one input: its solution, centroids, camera and
        catalog.

    Attributes
    ----------
    solved : bool
        Whether the attitude was found and verified.
    reason : str or None
        Why the frame is not solved (``"too_few_stars"``, ``"no_match"``, ...).
    quaternion : numpy.ndarray or None
        Camera-to-ICRS attitude, scalar first [w, x, y, z].
    ra_deg, dec_deg, roll_deg : float or None
        The boresight and the roll (docs/conventions.md).
    stars : pandas.DataFrame
        The identified stars: x, y, catalog_id, ra_deg, dec_deg, residual_arcsec.
        ``catalog_id`` is the HIP number for Hipparcos, the source id for a deeper
        catalog and the 0-based row for a random sky.

    Raises
    ------
    None
        Its properties never raise: an unsolved frame gives None and an empty table (a
        frame that cannot be read raises in :meth:`Solver.solve` instead).

    Examples
    --------
    Three centroids that are no stars of the sky: the frame is honestly not solved.

    >>> import numpy as np
    >>> import startrack
    >>> result = startrack.solve(np.array([[10.0, 20.0], [30.0, 40.0], [500.0, 600.0]]),
    ...                          fov_deg=20.0, size=(1024, 1024), sky="random")
    >>> result.solved, result.reason, result.quaternion
    (False, 'no_match', None)
    >>> result.to_dict()["status"], len(result.stars)
    ('not_solved', 0)
    """

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
        """A tracking Solver's lock state after this frame (startrack.tracking._lock_state); else
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

        from startrack.outputs import solved_wcs_header  # astropy: as above

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", FITSFixedWarning)
            wcs = WCS(solved_wcs_header(self.frame))
        # the header is a solution, not an image's: give the WCS the frame's size
        wcs.pixel_shape = (self.frame.camera.width, self.frame.camera.height)
        return wcs

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
