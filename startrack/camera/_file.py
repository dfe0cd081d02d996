"""Camera files (docs/conventions.md keys, JSON or TOML) read into a :class:`Camera`.

Every value is checked before use: sizes are positive integers (not ``"1024"``, ``true``
or ``1024.5``), numbers are finite, and the camera must make physical sense within the
documented bounds below; anything else is an :class:`InputError` naming the file and key.
"""

from __future__ import annotations

import json
import math
import tomllib
from pathlib import Path

from startrack.camera._distortion import distortion_from_dict
from startrack.camera._model import Camera
from startrack.errors import InputError, InputFileNotFoundError
from startrack.input_checks import FOV_DEG, IMAGE_SIDE_PX, check_number, check_table

CAMERA_KEYS = {"width", "height", "fov_deg", "focal_length_mm", "pixel_size_um", "cx", "cy",
               "distortion", "uncertainty"}  # uncertainty: calibrate's report, not read
FOCAL_LENGTH_MM = (1e-3, 1e5)  # 1 micron to 100 m
PIXEL_SIZE_UM = (1e-2, 1e3)  # 10 nm to 1 mm


def _size(data: dict, key: str, where: str) -> int:
    value = data[key]
    if isinstance(value, float) and math.isfinite(value) and value.is_integer():
        value = int(value)  # 1024.0 is 1024; 1024.5 is an error below
    return int(check_number(value, f"{where}: {key}", IMAGE_SIDE_PX))


def _principal_point(data: dict, key: str, size: int, where: str) -> float | None:
    """cx / cy: inside the image (pixel centres run 0..size-1, edges at -0.5, size-0.5)."""
    if data.get(key) is None:
        return None
    return float(check_number(data[key], f"{where}: {key}", low=-0.5, high=size - 0.5))


def _focal_px(data: dict, width: int, where: str) -> float:
    if "fov_deg" in data:
        if "focal_length_mm" in data or "pixel_size_um" in data:
            raise InputError(f"{where}: give fov_deg or focal_length_mm + pixel_size_um, "
                             "not both")
        fov = check_number(data["fov_deg"], f"{where}: fov_deg", FOV_DEG)
        return (width / 2.0) / math.tan(math.radians(fov) / 2.0)
    if "focal_length_mm" not in data or "pixel_size_um" not in data:
        raise InputError(f"{where}: needs fov_deg, or focal_length_mm and pixel_size_um")
    focal = check_number(data["focal_length_mm"], f"{where}: focal_length_mm",
                         low=FOCAL_LENGTH_MM[0], high=FOCAL_LENGTH_MM[1])
    pixel = check_number(data["pixel_size_um"], f"{where}: pixel_size_um",
                         low=PIXEL_SIZE_UM[0], high=PIXEL_SIZE_UM[1])
    f_px = focal * 1000.0 / pixel
    fov = math.degrees(2.0 * math.atan((width / 2.0) / f_px))
    if fov not in FOV_DEG:
        raise InputError(f"{where}: focal_length_mm {focal} and pixel_size_um {pixel} give a "
                         f"{fov:.4g} deg field of view across {width} px, outside "
                         f"{FOV_DEG} deg")
    return f_px


def camera_from_dict(data: dict, where: str = "camera") -> Camera:
    """A camera from the docs/conventions.md keys; unknown, missing or bad values are errors."""
    check_table(data, CAMERA_KEYS, where, "camera")
    if not isinstance(data.get("uncertainty", {}), dict):
        raise InputError(f"{where}: uncertainty must be a table")
    for key in ("width", "height"):
        if key not in data:
            raise InputError(f"{where}: missing key '{key}'")
    width, height = _size(data, "width", where), _size(data, "height", where)
    f_px = _focal_px(data, width, where)
    cx = _principal_point(data, "cx", width, where)
    cy = _principal_point(data, "cy", height, where)
    camera = Camera(width, height, float(f_px),
                    (width - 1) / 2.0 if cx is None else cx,
                    (height - 1) / 2.0 if cy is None else cy)
    return camera.with_distortion(distortion_from_dict(data.get("distortion"), where))


def load_camera(path: str | Path) -> Camera:
    """Read a camera file (JSON or TOML, chosen by extension; JSON otherwise)."""
    path = Path(path)
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise InputFileNotFoundError(f"{path}: no such camera file") from None
    except OSError as exc:
        raise InputError(f"{path}: cannot read camera file ({exc.strerror})") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(f"{path}: camera file is not UTF-8 text (byte {exc.start})") \
            from None
    kind = "TOML" if path.suffix.lower() == ".toml" else "JSON"  # .yaml, .csv: JSON
    try:
        data = tomllib.loads(text) if kind == "TOML" else json.loads(text)
    except (tomllib.TOMLDecodeError, json.JSONDecodeError) as exc:
        raise InputError(f"{path}: not valid {kind} ({exc})") from None
    return camera_from_dict(data, where=str(path))
