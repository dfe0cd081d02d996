"""Simulation configs: the TOML presets in configs/ ([camera], [sky], [sensor], [frames],
and the effects: [optics], [detector], [environment])."""

from __future__ import annotations

import dataclasses
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from startrack.camera import Camera, camera_from_dict
from startrack.errors import InputError
from startrack.input_checks import (
    FALSE_STARS,
    FRACTION,
    FRAMES,
    MAG_NOISE,
    RATE_DPS,
    SEED,
    TIME_TAG_ERROR_S,
    check_keys,
    check_number,
)
from startrack.io import resource_path
from startrack.simulate._effects import TABLES as EFFECT_TABLES
from startrack.simulate._effects import Effects, effects_from_dict
from startrack.simulate._sensor import SensorModel, sensor_from_dict
from startrack.sky import SkySpec

TABLES = ("camera", "sky", "sensor", "frames", *EFFECT_TABLES)


@dataclass(frozen=True)
class FrameOptions:
    """Per-run defaults a config's [frames] table may set; command options override them."""

    count: int = 3
    seed: int = 0
    missing: float = 0.0
    false_stars: int = 0
    mag_noise: float = 0.0
    hot_pixel_fraction: float = 0.5
    rate_dps: tuple[float, float, float] | None = None
    #: 1 sigma of a sequence frame's time-tag error, s (0: tagged at its true time)
    time_tag_error_s: float = 0.0


@dataclass(frozen=True)
class SimConfig:
    camera: Camera
    sky: SkySpec
    sensor: SensorModel
    frames: FrameOptions
    effects: Effects = field(default_factory=Effects)


# The 2011 paper's experiment (configs/paper2011.toml says the same).
DEFAULT_CONFIG = {
    "camera": {"width": 1024, "height": 1024, "fov_deg": 17.5},
    "sky": {"kind": "random", "n_stars": 2000, "seed": 0, "mag_limit": 6.5},
}


def _frames_from_dict(data: dict, where: str) -> FrameOptions:
    check_keys(data, (f.name for f in dataclasses.fields(FrameOptions)), where)
    checks = {"count": FRAMES, "seed": SEED, "missing": FRACTION, "false_stars": FALSE_STARS,
              "mag_noise": MAG_NOISE, "hot_pixel_fraction": FRACTION,
              "time_tag_error_s": TIME_TAG_ERROR_S}
    for key, bounds in checks.items():
        if key in data:
            check_number(data[key], f"{where}: {key}", bounds)
    if "rate_dps" in data:
        rate = data["rate_dps"]
        if not isinstance(rate, list) or len(rate) != 3:
            raise InputError(f"{where}: rate_dps must be a list of 3 numbers (deg/s)")
        rate = tuple(float(check_number(r, f"{where}: rate_dps", RATE_DPS)) for r in rate)
        data = {**data, "rate_dps": rate}
    return FrameOptions(**data)


def config_from_dict(data: dict, where: str = "config") -> SimConfig:
    """A simulation config from TOML-like tables; missing tables take the defaults."""
    unknown = set(data) - set(TABLES)
    if unknown:
        raise InputError(f"{where}: unknown table(s) {', '.join(sorted(unknown))} "
                         f"(expected {', '.join(TABLES)})")
    for name in TABLES:
        if name in data and not isinstance(data[name], dict):
            raise InputError(f"{where}: [{name}] must be a table")
    return SimConfig(
        camera=camera_from_dict(data.get("camera", DEFAULT_CONFIG["camera"]),
                                where=f"{where} [camera]"),
        sky=SkySpec.from_dict(data.get("sky", DEFAULT_CONFIG["sky"]), f"{where} [sky]"),
        sensor=sensor_from_dict(data.get("sensor", {}), where=f"{where} [sensor]"),
        frames=_frames_from_dict(data.get("frames", {}), f"{where} [frames]"),
        effects=effects_from_dict(data, where),
    )


def _preset_or(path: Path) -> Path:
    if path.exists() or len(path.parts) > 2 or (len(path.parts) == 2
                                                 and path.parts[0] != "configs"):
        return path
    try:
        return resource_path("configs", f"{path.stem}.toml")
    except InputError:
        return path  # the read below reports the missing file by the name given


def load_config(path: str | Path) -> SimConfig:
    """Read a TOML simulation config; every error names the file.

    A path that does not exist but names a shipped preset (``hipparcos20``,
    ``configs/hipparcos20.toml``) reads the preset, so the presets work after an install.
    """
    path = _preset_or(Path(path))
    try:
        data = tomllib.loads(path.read_text())
    except OSError as exc:
        raise InputError(f"{path}: cannot read config ({exc.strerror or exc})") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: not valid TOML ({exc})") from None
    return config_from_dict(data, where=str(path))
