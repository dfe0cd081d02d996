"""One validation layer for the numbers of every source: options, environment, files, API.

Every number a user gives (a command option, an environment variable, a camera file, a
config, an API keyword) passes :func:`check_number` or :func:`parse_number`: it must be a
number of the right type (an integer where one is needed; never a bool), finite and inside
a documented :class:`Bounds`. A failure is one line naming its source, e.g.
``--sigma-px: 1e+200 is out of range (0, 50]``, raised as :class:`NumberError` (an
:class:`InputError` and a ``ValueError``) or, for a value of the wrong type,
:class:`NumberTypeError` (an :class:`InputError` and a ``TypeError``). The bounds below are
listed in docs/limits.md.
"""

from __future__ import annotations

import math
import numbers
import os
from dataclasses import dataclass

from startrack.errors import InputError


class NumberError(InputError, ValueError):
    """A number that is not finite or not inside its documented range."""


class NumberTypeError(InputError, TypeError):
    """A value that is not a number (or not an integer where one is needed)."""


@dataclass(frozen=True)
class Bounds:
    """A documented range: ``[low, high]``, either end open or absent, integers only if
    ``integer``."""

    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False
    integer: bool = False

    def __str__(self) -> str:
        low = "-inf" if self.low is None else f"{self.low:g}"
        high = "inf" if self.high is None else f"{self.high:g}"
        return (f"{'(' if self.low_open or self.low is None else '['}{low}, {high}"
                f"{')' if self.high_open or self.high is None else ']'}")

    def __contains__(self, value: float) -> bool:
        if self.low is not None and (value < self.low or (self.low_open and value == self.low)):
            return False
        return self.high is None or not (value > self.high
                                         or (self.high_open and value == self.high))


# The documented ranges (docs/limits.md). Each is wide enough for any real camera or run
# and narrow enough that no stage overflows or allocates without bound.
FOV_DEG = Bounds(1e-3, 179.0)
FOV_TOLERANCE = Bounds(0.0, 0.5)
SIGMA_PX = Bounds(0.0, 50.0, low_open=True)
MAG_LIMIT = Bounds(-5.0, 30.0)
#: Julian years: proper motion and the Earth's orbit are meaningless far outside these
EPOCH_YEAR = Bounds(1000.0, 3000.0)
EXPTIME_S = Bounds(0.0, 366 * 86_400.0)  # a FITS exposure: at most a year (then a date)
TIMEOUT_MS = Bounds(0.0, 86_400_000.0)  # a day per input; 0: give up at once
MAX_STARS = Bounds(3, 10_000, integer=True)
PRIOR_SIGMA_DEG = Bounds(0.0, 90.0, low_open=True)
RA_DEG = Bounds(-360.0, 360.0)
DEC_DEG = Bounds(-90.0, 90.0)
ROLL_DEG = Bounds(-360.0, 360.0)
RADIUS_DEG = Bounds(0.0, 180.0, low_open=True)  # a pointing hint's cone
SCALE = Bounds(0.0, 1e6, low_open=True)  # a scale hint, in any of its units
PIXEL_SIZE_UM = Bounds(1e-2, 1e3)  # 10 nm to 1 mm
DOWNSAMPLE = Bounds(1, 64, integer=True)
IMAGE_SIDE_PX = Bounds(1, 100_000, integer=True)  # an image's width or height
FRAMES = Bounds(1, 1_000_000_000, integer=True)
SEED = Bounds(0, 2**63 - 1, integer=True)
#: each false star costs ~9 KB of scene and render work per frame
FALSE_STARS = Bounds(0, 10_000, integer=True)
FRACTION = Bounds(0.0, 1.0)
MAG_NOISE = Bounds(0.0, 10.0)
RATE_DPS = Bounds(-3600.0, 3600.0)  # per axis: ten turns a second
FPS = Bounds(1e-3, 1e5)
TIME_TAG_ERROR_S = Bounds(0.0, 10.0)  # a frame's time-tag error, 1 sigma: at most 10 s
THRESHOLD_ARCSEC = Bounds(0.0, 648_000.0, low_open=True)
JOBS = Bounds(1, 4096, integer=True)
CACHE_MAX_MB = Bounds(0.0, 1e9)  # a petabyte
IMAGE_PIXELS = Bounds(1, 10**12, integer=True)
PAIRS = Bounds(1, 10**12, integer=True)
#: the solver's numeric settings by keyword: ``identify``'s options and ``Solver``'s keywords
SOLVER_BOUNDS = {"fov_deg": FOV_DEG, "fov_tolerance": FOV_TOLERANCE, "sigma_px": SIGMA_PX,
                 "mag_limit": MAG_LIMIT, "epoch": EPOCH_YEAR, "max_stars": MAX_STARS,
                 "timeout_ms": TIMEOUT_MS, "prior_sigma_deg": PRIOR_SIGMA_DEG}


def _shown(value) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def check_number(value, where: str, bounds: Bounds | None = None, *, integer: bool = False,
                 low: float | None = None, high: float | None = None) -> float | int:
    """``value`` if it is a finite number of the right type within ``bounds`` (or within
    ``[low, high]``); else :class:`NumberTypeError` / :class:`NumberError` naming ``where``.

    Integers are Python or numpy integers (an integral float such as ``3.0`` is not);
    numbers are those and any real float; a bool is neither.
    """
    if bounds is None:
        bounds = Bounds(low, high, integer=integer)
    kind = numbers.Integral if bounds.integer else numbers.Real
    if isinstance(value, bool) or not isinstance(value, kind):
        raise NumberTypeError(f"{where}: must be {'an integer' if bounds.integer else 'a number'}"
                              f", got {_shown(value)}")
    try:  # a 400-digit JSON integer overflows a float
        finite = math.isfinite(value)
    except OverflowError:
        finite = False
    if not finite:
        raise NumberError(f"{where}: {_shown(value)} is not a finite number")
    if value not in bounds:
        raise NumberError(f"{where}: {_shown(value)} is out of range {bounds}")
    return int(value) if bounds.integer else value


def parse_number(value, where: str, bounds: Bounds) -> float | int:
    """A number given as text (an option, an environment variable) or already a number,
    checked by :func:`check_number`; an integer may be written ``1e9``."""
    if isinstance(value, str):
        text = value.strip()
        try:
            value = int(text) if bounds.integer else float(text)
        except ValueError:
            try:
                number = float(text)
            except ValueError:
                raise NumberTypeError(f"{where}: {text!r} is not a number") from None
            if bounds.integer and math.isfinite(number) and not number.is_integer():
                raise NumberTypeError(f"{where}: {text!r} is not an integer") from None
            value = int(number) if bounds.integer and math.isfinite(number) else number
    return check_number(value, where, bounds)


def env_number(name: str, default: float | int, bounds: Bounds) -> float | int:
    """The environment variable ``name`` as a number in ``bounds`` (``default`` when unset
    or empty); a bad value is an error naming the variable, never silently ignored."""
    text = os.environ.get(name, "").strip()
    return default if not text else parse_number(text, name, bounds)


def check_keywords(values: dict, bounds: dict[str, Bounds], where: str = "") -> None:
    """Check each given (not None) keyword of ``values`` against its bounds."""
    for key, value in values.items():
        if value is not None:
            check_number(value, f"{where}{key}", bounds[key])


def check_keys(data: dict, keys, where: str) -> None:
    """An :class:`InputError` naming ``where`` and every key of ``data`` not in ``keys``."""
    unknown = set(data) - set(keys)
    if unknown:
        raise InputError(f"{where}: unknown key(s) {', '.join(sorted(unknown))}")


def check_table(data, keys, where: str, kind: str) -> dict:
    """``data`` if it is a table (a dict) of ``kind`` keys, each one of ``keys``; else an
    :class:`InputError` naming ``where`` (a file's tables and the API's mappings alike)."""
    if not isinstance(data, dict):
        raise InputError(f"{where}: expected a table of {kind} keys")
    check_keys(data, keys, where)
    return data


def check_attitude(value, where: str) -> tuple[float, float, float]:
    """An attitude (ra, dec, roll) in degrees: exactly three numbers within range."""
    try:
        parts = tuple(value)
    except TypeError:
        parts = None
    if parts is None or isinstance(value, str) or len(parts) != 3:
        raise NumberTypeError(f"{where}: expected (ra, dec, roll) in degrees, got "
                              f"{_shown(value)}")
    return tuple(float(check_number(v, f"{where}: {name}", b)) for v, name, b in
                 zip(parts, ("ra", "dec", "roll"), (RA_DEG, DEC_DEG, ROLL_DEG), strict=True))

__all__ = [
    "Bounds", "CACHE_MAX_MB", "DEC_DEG", "DOWNSAMPLE", "EPOCH_YEAR", "EXPTIME_S", "FALSE_STARS",
    "FOV_DEG", "FOV_TOLERANCE", "FPS", "FRACTION", "FRAMES", "IMAGE_PIXELS", "IMAGE_SIDE_PX",
    "JOBS", "MAG_LIMIT", "MAG_NOISE", "MAX_STARS", "NumberError", "NumberTypeError", "PAIRS",
    "PIXEL_SIZE_UM", "PRIOR_SIGMA_DEG", "RADIUS_DEG", "RATE_DPS", "RA_DEG", "ROLL_DEG", "SCALE",
    "SEED", "SIGMA_PX", "SOLVER_BOUNDS", "THRESHOLD_ARCSEC", "TIME_TAG_ERROR_S", "TIMEOUT_MS",
    "check_attitude",
    "check_keys", "check_keywords", "check_number", "check_table", "env_number", "parse_number",
]
