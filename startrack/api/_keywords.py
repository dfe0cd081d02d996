"""The Python API's keywords checked and converted as the command line's options are.

Numbers go through startrack.input_checks (the same bounds as the options); ``camera`` may be a
:class:`Camera`, a camera file path or a mapping of camera-file keys (checked like a file);
``time`` ISO 8601 text, an astropy ``Time`` or a number (a Julian year, e.g. 2019.57);
``prior`` exactly (ra, dec, roll) in degrees. A bad value raises a ``ValueError`` or
``TypeError`` subclass whose one-line message names the keyword.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from pathlib import Path

from startrack.camera import Camera, camera_from_dict, load_camera
from startrack.errors import InputError, as_builtin
from startrack.input_checks import (
    EPOCH_YEAR,
    IMAGE_SIDE_PX,
    SOLVER_BOUNDS,
    NumberTypeError,
    check_attitude,
    check_keywords,
    check_number,
)
from startrack.solver import parse_time

#: the command line's options as :class:`startrack.Solver`'s keywords, for the errors that
#: shared code words for both (an API user never typed ``--size WxH``)
API_KEYWORDS = {
    "size": "size=(width, height)", "fov": "fov_deg=", "camera": "camera=",
    "fov-tolerance": "fov_tolerance", "sky": "sky=", "mag-limit": "mag_limit",
    "epoch": "epoch", "sigma-px": "sigma_px", "max-stars": "max_stars",
    "timeout-ms": "timeout_ms", "prior": "prior=(ra, dec, roll)",
    "prior-sigma-deg": "prior_sigma_deg", "time": "time=", "ra": "ra", "dec": "dec",
    "radius": "radius", "scale-low": "scale_low", "scale-high": "scale_high",
    "scale-units": "scale_units", "pixel-size": "pixel_size_um", "downsample": "downsample",
    "config": "config=", "method": "method=", "no-header-hints": "header_hints=False",
}
#: an option and its metavar if one follows ("--size WxH", "--fov DEG", "--camera FILE")
_OPTION = re.compile(r"--([a-z][a-z0-9-]*)(?: (?:WxH|DEG|FILE|RA,DEC,ROLL|UM|N)\b)?")


def keyword_message(text: str) -> str:
    """An error message with the command line's options named as the API's keywords."""
    return _OPTION.sub(lambda m: API_KEYWORDS.get(m.group(1), m.group(0)), text)


def check_solver_numbers(**values) -> None:
    """Each numeric keyword of :class:`startrack.Solver` within its documented range."""
    check_keywords(values, SOLVER_BOUNDS)


def api_camera(camera) -> Camera | None:
    """A Camera from a Camera, a camera file path or a mapping of camera-file keys."""
    if camera is None or isinstance(camera, Camera):
        return camera
    try:
        if isinstance(camera, Mapping):
            return camera_from_dict(dict(camera), where="camera")
        if isinstance(camera, str | Path):
            if not Path(camera).is_file():
                raise FileNotFoundError(f"camera: no camera file {str(camera)!r}")
            return load_camera(camera)
    except InputError as exc:  # the API's errors are built-in subclasses (conventions)
        raise as_builtin(exc) from None
    raise NumberTypeError(f"camera: expected a Camera, a camera file path or a mapping of "
                          f"camera keys, got {type(camera).__name__}")


def api_time(time):
    """An astropy Time from ISO 8601 text, a Time, or a number taken as a Julian year."""
    if time is None:
        return None
    from astropy.time import Time  # astropy: loaded only when a time is given

    if isinstance(time, Time):
        return time
    if isinstance(time, str):
        return parse_time(time, where="time")
    year = check_number(time, "time (a Julian year)", EPOCH_YEAR)
    return Time(float(year), format="jyear", scale="utc")


def api_prior(prior) -> tuple[float, float, float] | None:
    """``prior`` as (ra, dec, roll) degrees; (1, 2) or a bare number is an error."""
    return None if prior is None else check_attitude(prior, "prior")


def api_size(size) -> tuple[int, int] | None:
    """``size`` as (width, height) pixels."""
    if size is None:
        return None
    try:
        width, height = size
    except (TypeError, ValueError):
        raise NumberTypeError(f"size: expected (width, height) in pixels, got {size!r}") \
            from None
    return (int(check_number(width, "size: width", IMAGE_SIDE_PX)),
            int(check_number(height, "size: height", IMAGE_SIDE_PX)))
