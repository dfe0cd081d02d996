"""The JSON file beside each simulated frame: the camera, the sky and the true attitude;
and the columns of the folder's truth.csv and stars.csv (docs/conventions.md)."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from startrack.attitude import from_quaternion
from startrack.camera import Camera, camera_from_dict
from startrack.errors import InputError, StartrackWarning
from startrack.io._sky_spec import SkySpec

#: truth.csv: one row per frame, its file and true attitude (camera to ICRS)
TRUTH_COLUMNS = ["frame", "file", "qw", "qx", "qy", "qz", "ra_deg", "dec_deg", "roll_deg"]
#: stars.csv: one row per star drawn in a frame; false stars have catalog_id -1
STARS_COLUMNS = ["frame", "x", "y", "flux", "magnitude", "catalog_id", "is_false"]


def sidecar_path_for(image_path: str | Path) -> Path:
    """``frame_0000.png`` -> ``frame_0000.json`` (same folder, same stem)."""
    return Path(image_path).with_suffix(".json")


def with_sidecars(inputs) -> list[Path]:
    """The inputs and the JSON beside each (what an output must never overwrite)."""
    paths = [Path(p) for p in inputs]
    return paths + [sidecar_path_for(p) for p in paths]


def is_sidecar_data(data) -> bool:
    """Whether parsed JSON is a startrack frame sidecar: an object with a ``camera`` and a
    ``sky`` object (what ``simulate`` writes), not any JSON that happens to share a stem."""
    return (isinstance(data, dict) and isinstance(data.get("camera"), dict)
            and isinstance(data.get("sky"), dict))


def find_sidecar(input_path: str | Path) -> Path | None:
    """The sidecar beside ``input_path``, or None; another JSON there is ignored with a
    warning rather than taken for the frame's camera and sky."""
    path = sidecar_path_for(input_path)
    if path == Path(input_path) or not path.is_file():
        return None
    try:
        data = json.loads(path.read_bytes())
    except (OSError, ValueError):  # unreadable or not JSON (ValueError covers bad UTF-8)
        data = None
    if is_sidecar_data(data):
        return path
    warnings.warn(f"{path}: not a startrack sidecar (no 'camera' and 'sky' objects); "
                  f"ignored for {Path(input_path).name}", StartrackWarning, stacklevel=2)
    return None


def read_sidecar(path: str | Path) -> tuple[Camera, SkySpec, Rotation | None]:
    """Camera, sky and (if recorded) the true attitude from a frame's sidecar JSON."""
    path = Path(path)
    try:
        data = json.loads(path.read_bytes())
    except OSError as exc:
        raise InputError(f"{path}: cannot read sidecar ({exc.strerror or exc})") from None
    except ValueError as exc:  # JSONDecodeError, or bytes that are not UTF-8
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
            with np.errstate(over="ignore"):
                norm = np.sqrt(np.sum(q * q)) if q.shape == (4,) else np.nan
            if not np.all(np.isfinite(q)) or not 1e-6 < norm < 1e6:
                raise ValueError("need 4 finite numbers, a unit quaternion")
            rotation = from_quaternion(q)
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(f"{path}: bad attitude quaternion ({exc})") from None
    return camera, sky, rotation
