"""Hints that narrow the search: where the boresight is, how large the field is.

``--ra/--dec/--radius`` (the boresight lies within ``radius`` of (ra, dec)) and
``--scale-low/--scale-high/--scale-units`` (solve-field's meanings) come from the user; a
FITS input's celestial WCS gives both by default (:func:`header_hints`). A hint never
loosens verification: the stars the matchers may use are cut to the cone of
:func:`cone_radius_deg` around the hinted pointing, which holds every catalog star of any
frame whose boresight lies within the radius, so verifying such a frame against the cut
catalog is verifying it against the whole one, with the same bound; an answer whose
boresight lies outside the radius is refused (:func:`within_hint`). The field of view
range becomes a nominal FOV and tolerance (:func:`fov_range_deg`).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from startrack.camera import Camera
from startrack.defaults import SCALE_UNITS
from startrack.errors import InputError
from startrack.input_checks import (
    DEC_DEG,
    EXPTIME_S,
    FOV_DEG,
    PIXEL_SIZE_UM,
    RA_DEG,
    RADIUS_DEG,
    SCALE,
    check_number,
)
from startrack.io import FITS_SUFFIXES
from startrack.sky import Catalog, radec_to_vectors
from startrack.solver._aberration import fits_time

#: a FITS header's pointing is trusted to within one field of view
HEADER_RADIUS_FIELDS = 1.0
#: a FITS header's scale is trusted to within this fraction either way
HEADER_SCALE_TOLERANCE = 0.05
#: added to the cone, degrees: the catalog is carried by proper motion and aberration
CONE_MARGIN_DEG = 0.1


@dataclass(frozen=True)
class Pointing:
    """The boresight lies within ``radius_deg`` of (``ra_deg``, ``dec_deg``)."""

    ra_deg: float
    dec_deg: float
    radius_deg: float

    def __post_init__(self) -> None:
        check_number(self.ra_deg, "--ra", RA_DEG)
        check_number(self.dec_deg, "--dec", DEC_DEG)
        check_number(self.radius_deg, "--radius", RADIUS_DEG)


@dataclass(frozen=True)
class Scale:
    """A range of image scales in solve-field's units; ``pixel_um`` for ``focalmm``."""

    low: float
    high: float
    units: str = "degwidth"
    pixel_um: float | None = None

    def __post_init__(self) -> None:
        if self.units not in SCALE_UNITS:
            raise InputError(f"--scale-units must be one of {', '.join(SCALE_UNITS)}, got "
                             f"{self.units!r}")
        check_number(self.low, "--scale-low", SCALE)
        check_number(self.high, "--scale-high", SCALE)
        if not 0 < self.low <= self.high:
            raise InputError(f"--scale-low and --scale-high must satisfy 0 < low <= high, "
                             f"got {self.low}, {self.high}")
        if self.units == "focalmm" and self.pixel_um is None:
            raise InputError("--scale-units focalmm needs the pixel size (--pixel-size UM)")
        if self.pixel_um is not None:
            check_number(self.pixel_um, "--pixel-size", PIXEL_SIZE_UM)

    def fov_deg(self, value: float, width: int) -> float:
        """The horizontal FOV (degrees) of an image ``width`` pixels wide at ``value``."""
        if self.units == "degwidth":
            return float(value)
        half_rad = (width / 2.0) * (math.radians(value / 3600.0) if self.units ==
                                    "arcsecperpix" else self.pixel_um / 1000.0 / value)
        return math.degrees(2.0 * math.atan(half_rad))


@dataclass(frozen=True)
class Hints:
    """What the user (or a FITS header, ``from_header``) says about the answer."""

    pointing: Pointing | None = None
    scale: Scale | None = None
    from_header: bool = False

    def __bool__(self) -> bool:
        return self.pointing is not None or self.scale is not None


def fov_range_deg(scale: Scale, width: int) -> tuple[float, float]:
    """The nominal FOV and the fractional tolerance that cover ``scale`` for ``width``."""
    a, b = sorted((scale.fov_deg(scale.low, width), scale.fov_deg(scale.high, width)))
    # within --fov's range: below it (1e-5 arcsec/px) the search ran 40 s for nothing
    if not (a in FOV_DEG and b in FOV_DEG):
        raise InputError(f"--scale-low/--scale-high: a field of view of {a:g} to {b:g} deg "
                         f"is outside {FOV_DEG} deg")
    return (a + b) / 2.0, (b - a) / (b + a)


def cone_radius_deg(pointing: Pointing, camera: Camera | None, tolerance: float,
                    widest_fov_deg: float) -> float:
    """The cone around the hinted pointing that holds every star of every frame whose
    boresight lies within the radius: the radius, half the widest diagonal, a margin."""
    if camera is None:
        half_diag = math.degrees(math.atan(math.tan(math.radians(widest_fov_deg) / 2.0)
                                           * math.sqrt(2.0)))
    else:
        half_diag = camera.half_diagonal_deg * (1.0 + tolerance) * 1.02
    return min(180.0, pointing.radius_deg + half_diag + CONE_MARGIN_DEG)


def cut_to_cone(catalog: Catalog, pointing: Pointing, radius_deg: float) -> Catalog:
    """The stars of ``catalog`` within ``radius_deg`` of the hinted pointing (rows stay
    brightest first; ids and source unchanged)."""
    centre = radec_to_vectors(pointing.ra_deg, pointing.dec_deg)
    inside = catalog.vectors @ centre >= math.cos(math.radians(radius_deg))
    return catalog.subset(inside)


def within_hint(rotation, pointing: Pointing) -> bool:
    """Whether a solved attitude's boresight lies within the hinted radius."""
    boresight = rotation.apply([0.0, 0.0, 1.0])
    centre = radec_to_vectors(pointing.ra_deg, pointing.dec_deg)
    angle = math.degrees(math.acos(float(np.clip(boresight @ centre, -1.0, 1.0))))
    return angle <= pointing.radius_deg + 1e-9


def header_hints(path: Path | None, size: tuple[int, int] | None) -> Hints | None:
    """Pointing and scale from a FITS file's celestial WCS, or None (no FITS, no WCS, or
    a WCS that says nothing usable). The pointing is the image centre's, good to
    :data:`HEADER_RADIUS_FIELDS` fields; the scale to :data:`HEADER_SCALE_TOLERANCE`."""
    header = fits_header(path)
    if header is None or size is None or not any(
            str(header.get(f"CTYPE{i}", "")).upper().startswith(("RA", "DEC"))
            for i in (1, 2)):
        return None  # no celestial WCS: astropy.wcs (slow to import) is not needed
    from astropy.wcs import WCS, FITSFixedWarning  # astropy: only for a FITS header's WCS
    from astropy.wcs.utils import proj_plane_pixel_scales  # astropy: as above

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", FITSFixedWarning)
            wcs = WCS(header).celestial
        if not wcs.has_celestial or wcs.naxis != 2:
            return None
        ra, dec = wcs.all_pix2world([(size[0] - 1) / 2.0], [(size[1] - 1) / 2.0], 0)
        deg_per_px = float(np.mean(proj_plane_pixel_scales(wcs)))
    except (ValueError, KeyError, TypeError, MemoryError, AttributeError):
        return None
    fov = math.degrees(2.0 * math.atan(size[0] / 2.0 * math.radians(deg_per_px)))
    if not (np.isfinite(ra[0]) and np.isfinite(dec[0]) and 0 < fov < 179):
        return None
    pointing = _on_grid(float(ra[0]), float(dec[0]), HEADER_RADIUS_FIELDS * fov)
    scale = Scale(fov * (1 - HEADER_SCALE_TOLERANCE), fov * (1 + HEADER_SCALE_TOLERANCE))
    return Hints(pointing, scale, from_header=True)


def _on_grid(ra: float, dec: float, radius: float) -> Pointing:
    """The pointing moved to a grid a quarter of the radius wide, the radius grown to
    cover the move: nearby frames of a batch share one cone, and its tables."""
    step = radius / 4.0
    dec_grid = float(np.clip(round(dec / step) * step, -90.0, 90.0))
    ra_step = step / max(math.cos(math.radians(dec_grid)), 1e-3)
    ra_grid = (round(ra / ra_step) * ra_step) % 360.0
    return Pointing(ra_grid, dec_grid, radius + step)


def fits_header(path: Path | None):
    """The primary (or first image) header of a FITS file; None for any other input."""
    if path is None or Path(path).suffix.lower() not in FITS_SUFFIXES:
        return None
    from astropy.io import fits  # astropy: only for a FITS input

    try:
        with fits.open(path, memmap=False) as hdus:
            for hdu in hdus:
                if getattr(hdu, "is_image", False) and hdu.header.get("NAXIS", 0) >= 2:
                    return hdu.header.copy()
    except (OSError, ValueError, TypeError):
        return None
    return None


def header_time(path: Path | None):
    """The middle of a FITS exposure (DATE-OBS plus half of EXPTIME) as an astropy Time,
    or None when the header has no DATE-OBS."""
    when = fits_time(path) if path is not None else None
    if when is None:
        return None
    header = fits_header(path)
    exptime = None if header is None else header.get("EXPTIME")
    if isinstance(exptime, int | float) and math.isfinite(exptime) and exptime > 0:
        from astropy import units as u  # astropy: only with a FITS EXPTIME

        # 1e300 s moved the time past erfa's table: a traceback, not a one-line error
        check_number(exptime, f"{path}: EXPTIME", EXPTIME_S)

        when = when + exptime / 2.0 * u.s
    return when


def user_hints(ra=None, dec=None, radius=None, scale_low=None, scale_high=None,
               scale_units: str = "degwidth", pixel_size_um: float | None = None, *,
               fov_given: bool = False) -> Hints | None:
    """The user's :class:`Hints` (``identify``'s options, the API's keywords); None when
    none is given. The three of a pointing and the two bounds of a scale come together;
    a scale range replaces a field of view, it does not add to one."""
    pointing = scale = None
    radec = (ra, dec, radius)
    if any(v is not None for v in radec):
        if any(v is None for v in radec):
            raise InputError("give --ra, --dec and --radius together")
        pointing = Pointing(*radec)
    if scale_low is not None or scale_high is not None:
        if scale_low is None or scale_high is None:
            raise InputError("give --scale-low and --scale-high together")
        if fov_given:
            raise InputError("give --fov/--camera or --scale-low/--scale-high, not both")
        scale = Scale(scale_low, scale_high, scale_units, pixel_size_um)
    return Hints(pointing, scale) or None
