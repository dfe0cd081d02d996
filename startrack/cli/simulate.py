"""`startrack simulate`: render CCD frames of a sky with the truth beside each frame."""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import sys
import tomllib
from dataclasses import dataclass
from pathlib import Path

import click
import numpy as np

from startrack.atomic import atomic_text
from startrack.camera import Camera, camera_from_dict, load_camera
from startrack.cli import main
from startrack.errors import InputError
from startrack.sensor import SensorModel, sensor_from_dict
from startrack.sidecar import sidecar_path_for
from startrack.sky import SKY_KINDS, SkySpec

DEFAULT_OUT = Path("out/simulate")
TABLES = ("camera", "sky", "sensor", "frames")


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


@dataclass(frozen=True)
class SimConfig:
    camera: Camera
    sky: SkySpec
    sensor: SensorModel
    frames: FrameOptions


# The 2011 paper's experiment (configs/paper2011.toml and configs/default.toml say the same).
DEFAULT_CONFIG = {
    "camera": {"width": 1024, "height": 1024, "fov_deg": 17.5},
    "sky": {"kind": "random", "n_stars": 2000, "seed": 0, "mag_limit": 6.5},
}


def _number(value, where: str, *, integer: bool = False, low: float | None = None,
            high: float | None = None) -> float | int:
    ok = isinstance(value, int) if integer else isinstance(value, int | float)
    if isinstance(value, bool) or not ok or not math.isfinite(value):
        raise InputError(f"{where} must be {'an integer' if integer else 'a number'}, "
                         f"got {value!r}")
    if low is not None and value < low:
        raise InputError(f"{where} must be >= {low}, got {value!r}")
    if high is not None and value > high:
        raise InputError(f"{where} must be <= {high}, got {value!r}")
    return value


def _sky_from_dict(data: dict, where: str) -> SkySpec:
    unknown = set(data) - {f.name for f in dataclasses.fields(SkySpec)}
    if unknown:
        raise InputError(f"{where}: unknown key(s) {', '.join(sorted(unknown))}")
    if data.get("kind", "random") not in SKY_KINDS:
        raise InputError(f"{where}: kind must be one of {', '.join(SKY_KINDS)}")
    checks = {"n_stars": dict(integer=True, low=1), "seed": dict(integer=True, low=0),
              "mag_limit": {}, "epoch": {}, "min_separation_deg": dict(low=0)}
    for key, rule in checks.items():
        if key in data:
            _number(data[key], f"{where}: {key}", **rule)
    return SkySpec(**data)


def _frames_from_dict(data: dict, where: str) -> FrameOptions:
    unknown = set(data) - {f.name for f in dataclasses.fields(FrameOptions)}
    if unknown:
        raise InputError(f"{where}: unknown key(s) {', '.join(sorted(unknown))}")
    checks = {"count": dict(integer=True, low=1), "seed": dict(integer=True, low=0),
              "missing": dict(low=0, high=1), "false_stars": dict(integer=True, low=0),
              "mag_noise": dict(low=0), "hot_pixel_fraction": dict(low=0, high=1)}
    for key, rule in checks.items():
        if key in data:
            _number(data[key], f"{where}: {key}", **rule)
    if "rate_dps" in data:
        rate = data["rate_dps"]
        if not isinstance(rate, list) or len(rate) != 3:
            raise InputError(f"{where}: rate_dps must be a list of 3 numbers (deg/s)")
        data = {**data, "rate_dps": tuple(float(_number(r, f"{where}: rate_dps")) for r in rate)}
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
        sky=_sky_from_dict(data.get("sky", DEFAULT_CONFIG["sky"]), f"{where} [sky]"),
        sensor=sensor_from_dict(data.get("sensor", {}), where=f"{where} [sensor]"),
        frames=_frames_from_dict(data.get("frames", {}), f"{where} [frames]"),
    )


def load_config(path: str | Path) -> SimConfig:
    """Read a TOML simulation config (see configs/); every error names the file."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text())
    except OSError as exc:
        raise InputError(f"{path}: cannot read config ({exc.strerror or exc})") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: not valid TOML ({exc})") from None
    return config_from_dict(data, where=str(path))


def _triple(names: str):
    def parse(ctx, param, value):
        if value is None:
            return None
        try:
            parts = tuple(float(p) for p in value.split(","))
        except ValueError:
            parts = ()
        if len(parts) != 3 or not all(math.isfinite(p) for p in parts):
            raise click.BadParameter(f"expected three numbers {names}, got {value!r}")
        return parts
    return parse


@main.command()
@click.option("--config", "config_path", type=click.Path(dir_okay=False),
              help="TOML preset (see configs/); default: the 2011 paper's experiment.")
@click.option("--sky", type=click.Choice(SKY_KINDS), help="Sky kind (overrides the config).")
@click.option("--mag-limit", type=float, help="Faintest catalog magnitude to use.")
@click.option("--frames", "count", type=click.IntRange(min=1), help="Number of frames.")
@click.option("--seed", type=click.IntRange(min=0), help="Seed of attitudes and noise.")
@click.option("--out", "out_dir", type=click.Path(file_okay=False), default=str(DEFAULT_OUT),
              show_default=True, help="Output folder.")
@click.option("--attitude", callback=_triple("RA,DEC,ROLL"),
              help="Fixed attitude RA,DEC,ROLL in degrees (default: random per frame).")
@click.option("--false-stars", type=click.IntRange(min=0), help="False stars per frame.")
@click.option("--missing", type=click.FloatRange(0, 1), help="Star dropout probability.")
@click.option("--mag-noise", type=click.FloatRange(min=0), help="Magnitude noise sigma.")
@click.option("--rate", callback=_triple("WX,WY,WZ"),
              help="Angular rate in the camera frame, deg/s, for motion blur.")
@click.option("--fits", "write_fits_too", is_flag=True, help="Also write FITS with a WCS.")
@click.option("--camera", "camera_path", type=click.Path(dir_okay=False),
              help="Camera file (JSON or TOML), overrides the config's [camera].")
def simulate(config_path, sky, mag_limit, count, seed, out_dir, attitude, false_stars,
             missing, mag_noise, rate, write_fits_too, camera_path) -> None:
    """Render frames of a sky, with truth.csv, stars.csv and a JSON sidecar per frame."""
    cfg = load_config(config_path) if config_path else config_from_dict(DEFAULT_CONFIG,
                                                                        "default config")
    camera = load_camera(camera_path) if camera_path else cfg.camera
    spec = cfg.sky
    if sky is not None:
        spec = dataclasses.replace(spec, kind=sky)
    if mag_limit is not None:
        if not math.isfinite(mag_limit):
            raise click.BadParameter("must be finite", param_hint="--mag-limit")
        spec = dataclasses.replace(spec, mag_limit=mag_limit)
    given = dict(count=count, seed=seed, false_stars=false_stars, missing=missing,
                 mag_noise=mag_noise, rate_dps=rate)
    opts = dataclasses.replace(cfg.frames, **{k: v for k, v in given.items() if v is not None})
    if attitude is not None and not -90.0 <= attitude[1] <= 90.0:
        raise click.BadParameter(f"Dec must be in [-90, 90], got {attitude[1]}",
                                 param_hint="--attitude")
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise click.BadParameter(f"{out} exists and is not a folder", param_hint="--out")
    try:
        _run(camera, spec, cfg.sensor, opts, out, attitude, write_fits_too)
    except OSError as exc:  # every file is atomic, so nothing half-written is left behind
        raise InputError(f"{out}: cannot write output ({exc.strerror or exc})") from None


def _run(camera: Camera, spec: SkySpec, sensor: SensorModel, opts: FrameOptions, out: Path,
         attitude: tuple[float, float, float] | None, with_fits: bool) -> None:
    from tqdm import tqdm

    from startrack.attitude import from_radec_roll, to_quaternion, to_radec_roll
    from startrack.imageio import write_fits, write_png16
    from startrack.render import render_frame
    from startrack.scene import observe
    from startrack.sky import load_sky
    from startrack.wcs import wcs_header

    catalog = load_sky(spec, camera)  # before any output: a bad sky leaves no files
    fixed = from_radec_roll(*attitude) if attitude is not None else None
    truth_rows, star_rows = [], []
    bar = tqdm(range(opts.count), file=sys.stderr, unit="frame", desc="simulate",
               disable=not sys.stderr.isatty())
    for i in bar:
        rng = np.random.default_rng([opts.seed, i])  # each frame reproducible on its own
        rotation = fixed if fixed is not None else _random_rotation(rng)
        scene = observe(catalog, camera, rotation, rng, missing=opts.missing,
                        false_stars=opts.false_stars, mag_noise=opts.mag_noise,
                        hot_pixel_fraction=opts.hot_pixel_fraction)
        image = render_frame(scene, camera, sensor, rng, angular_rate_dps=opts.rate_dps)
        name = f"frame_{i:04d}"
        png = out / f"{name}.png"
        write_png16(png, image)
        if with_fits:
            write_fits(out / f"{name}.fits", image, wcs_header(camera, rotation))
        q = [float(c) for c in to_quaternion(rotation)]
        ra, dec, roll = to_radec_roll(rotation)
        sidecar = {
            "image": png.name, "frame": i, "seed": opts.seed,
            "camera": camera.to_dict(), "sky": spec.to_dict(),
            "attitude": {"quaternion": q, "ra_deg": ra, "dec_deg": dec, "roll_deg": roll},
            "sensor": sensor.to_dict(),
            "frames": {"missing": opts.missing, "false_stars": opts.false_stars,
                       "mag_noise": opts.mag_noise, "rate_dps": opts.rate_dps},
        }
        with atomic_text(sidecar_path_for(png)) as fh:
            json.dump(sidecar, fh, indent=2)
            fh.write("\n")
        truth_rows.append([i, png.name, *q, ra, dec, roll])
        flux = sensor.electrons_from_mag(scene.mag)
        for j in range(len(scene)):  # a few dozen rows per frame, for the CSV writer
            star_rows.append([i, float(scene.x[j]), float(scene.y[j]), float(flux[j]),
                              float(scene.mag[j]), int(scene.catalog_id[j]),
                              int(scene.is_false[j])])
    _write_csv(out / "truth.csv", ["frame", "file", "qw", "qx", "qy", "qz", "ra_deg",
                                   "dec_deg", "roll_deg"], truth_rows)
    _write_csv(out / "stars.csv", ["frame", "x", "y", "flux", "magnitude", "catalog_id",
                                   "is_false"], star_rows)
    click.echo(f"wrote {opts.count} frame(s) to {out}/ (truth.csv, stars.csv, "
               f"frame_*.png{', frame_*.fits' if with_fits else ''}, frame_*.json)")


def _random_rotation(rng: np.random.Generator):
    from startrack.attitude import random_attitudes

    return random_attitudes(1, rng)[0]


def _write_csv(path: Path, header: list[str], rows: list[list]) -> None:
    with atomic_text(path) as fh:
        writer = csv.writer(fh)
        writer.writerow(header)
        writer.writerows(rows)
