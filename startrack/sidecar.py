"""The JSON file beside each simulated frame: the camera, the sky and the true attitude."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from startrack.attitude import from_quaternion
from startrack.camera import Camera
from startrack.camera_file import camera_from_dict
from startrack.errors import InputError
from startrack.sky import SkySpec


def sidecar_path_for(image_path: str | Path) -> Path:
    """``frame_0000.png`` -> ``frame_0000.json`` (same folder, same stem)."""
    return Path(image_path).with_suffix(".json")


def read_sidecar(path: str | Path) -> tuple[Camera, SkySpec, Rotation | None]:
    """Camera, sky and (if recorded) the true attitude from a frame's sidecar JSON."""
    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except OSError as exc:
        raise InputError(f"{path}: cannot read sidecar ({exc.strerror or exc})") from None
    except json.JSONDecodeError as exc:
        raise InputError(f"{path}: not valid JSON ({exc})") from None
    if not isinstance(data, dict) or "camera" not in data or "sky" not in data:
        raise InputError(f"{path}: a sidecar needs 'camera' and 'sky' entries")
    camera = camera_from_dict(data["camera"], where=f"{path} camera")
    if not isinstance(data["sky"], dict):
        raise InputError(f"{path}: 'sky' must be an object")
    try:
        sky = SkySpec.from_dict(data["sky"])
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None
    except TypeError as exc:
        raise InputError(f"{path}: bad sky entry ({exc})") from None
    rotation = None
    attitude = data.get("attitude")
    if attitude is not None:
        try:
            q = np.asarray(attitude["quaternion"], dtype=np.float64)
            if q.shape != (4,) or not np.all(np.isfinite(q)) or np.linalg.norm(q) == 0:
                raise ValueError("need 4 finite numbers")
            rotation = from_quaternion(q)
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(f"{path}: bad attitude quaternion ({exc})") from None
    return camera, sky, rotation
