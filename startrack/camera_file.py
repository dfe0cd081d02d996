"""Camera files (shared/interfaces.md keys, JSON or TOML) read into a :class:`Camera`."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

from startrack.camera import Camera
from startrack.distortion import distortion_from_dict
from startrack.errors import InputError

CAMERA_KEYS = {"width", "height", "fov_deg", "focal_length_mm", "pixel_size_um", "cx", "cy",
               "distortion"}


def camera_from_dict(data: dict, where: str = "camera") -> Camera:
    """A camera from the interfaces.md keys; unknown or missing keys are errors."""
    if not isinstance(data, dict):
        raise InputError(f"{where}: expected a table of camera keys")
    unknown = set(data) - CAMERA_KEYS
    if unknown:
        raise InputError(f"{where}: unknown key(s) {', '.join(sorted(unknown))}")
    for key in ("width", "height"):
        if key not in data:
            raise InputError(f"{where}: missing key '{key}'")
    try:
        width, height = int(data["width"]), int(data["height"])
        cx, cy = data.get("cx"), data.get("cy")
        if "fov_deg" in data:
            if "focal_length_mm" in data or "pixel_size_um" in data:
                raise InputError(f"{where}: give fov_deg or focal_length_mm + pixel_size_um, "
                                 "not both")
            return Camera.from_fov(width, height, float(data["fov_deg"]), cx, cy,
                                   _distortion(data, where))
        if "focal_length_mm" in data and "pixel_size_um" in data:
            return Camera.from_optics(width, height, float(data["focal_length_mm"]),
                                      float(data["pixel_size_um"]), cx, cy,
                                      _distortion(data, where))
    except (TypeError, ValueError) as exc:
        raise InputError(f"{where}: bad value ({exc})") from None
    raise InputError(f"{where}: needs fov_deg, or focal_length_mm and pixel_size_um")


def _distortion(data: dict, where: str):
    return distortion_from_dict(data.get("distortion"), where)


def load_camera(path: str | Path) -> Camera:
    """Read a camera file (JSON or TOML, chosen by extension; JSON otherwise)."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise InputError(f"{path}: cannot read camera file ({exc.strerror})") from None
    try:
        data = tomllib.loads(text) if path.suffix.lower() == ".toml" else json.loads(text)
    except (tomllib.TOMLDecodeError, json.JSONDecodeError) as exc:
        raise InputError(f"{path}: not valid {path.suffix.lstrip('.') or 'JSON'} ({exc})") \
            from None
    return camera_from_dict(data, where=str(path))
