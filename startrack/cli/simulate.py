"""`startrack simulate`: render CCD frames of a sky with the truth beside each frame."""

from __future__ import annotations

import csv
import dataclasses
import json
import sys
from pathlib import Path

import click
import numpy as np

from startrack.cache import atomic_text
from startrack.camera import Camera
from startrack.camera_file import load_camera
from startrack.cli import Terminated, main
from startrack.cli.options import Number, triple
from startrack.config import DEFAULT_CONFIG, FrameOptions, config_from_dict, load_config
from startrack.errors import InputError
from startrack.image_header import check_pixels
from startrack.outputs import check_out_folder, remove_own
from startrack.sensor import SensorModel
from startrack.sidecar import sidecar_path_for
from startrack.sky import SKY_KINDS, SkySpec, resolve_sky
from startrack.validate import (
    FALSE_STARS,
    FPS,
    FRACTION,
    FRAMES,
    MAG_LIMIT,
    MAG_NOISE,
    RATE_DPS,
    SEED,
)

DEFAULT_OUT = Path("out/simulate")
OWN_FILES = ("frame_*.png", "frame_*.json", "frame_*.fits", "truth.csv", "stars.csv")


@main.command()
@click.option("--config", "config_path", type=click.Path(dir_okay=False),
              help="TOML preset: a file, or a shipped preset by name (hipparcos20, "
                   "paper2011, radial_triangles, realsky); default: the 2011 paper's experiment.")
@click.option("--sky", type=click.Choice(SKY_KINDS), help="Sky kind (overrides the config).")
@click.option("--mag-limit", type=Number(MAG_LIMIT), help="Faintest catalog magnitude to use.")
@click.option("--frames", "count", type=Number(FRAMES), help="Number of frames.")
@click.option("--seed", type=Number(SEED), help="Seed of attitudes and noise.")
@click.option("--out", "out_dir", type=click.Path(file_okay=False), default=str(DEFAULT_OUT),
              show_default=True, help="Output folder.")
@click.option("--attitude", callback=triple("RA,DEC,ROLL"),
              help="Fixed attitude RA,DEC,ROLL in degrees (default: random per frame).")
@click.option("--false-stars", type=Number(FALSE_STARS), help="False stars per frame.")
@click.option("--missing", type=Number(FRACTION), help="Star dropout probability.")
@click.option("--mag-noise", type=Number(MAG_NOISE), help="Magnitude noise sigma.")
@click.option("--rate", callback=triple("WX,WY,WZ", RATE_DPS),
              help="Angular rate in the camera frame, deg/s: motion blur, and with --fps "
                   "the frames form one trajectory (frame k at R0 exp(w k / fps)).")
@click.option("--fps", type=Number(FPS),
              help="Frames per second: the frames are one sequence (from --attitude, else "
                   "a random start), turning at --rate or following --profile.")
@click.option("--profile", "profile_path", type=click.Path(dir_okay=False),
              help="Attitude profile CSV (t,qw,qx,qy,qz; seconds, camera-to-ICRS "
                   "quaternion), SLERP-interpolated at --fps; frames: as many as it covers.")
@click.option("--fits", "write_fits_too", is_flag=True, help="Also write FITS with a WCS.")
@click.option("--camera", "camera_path", type=click.Path(dir_okay=False),
              help="Camera file (JSON or TOML), overrides the config's [camera]; its "
                   "distortion is rendered.")
@click.option("--overwrite", is_flag=True,
              help="Write into a non-empty --out, first removing the frames, sidecars and "
                   "CSVs an earlier simulate left there.")
@click.option("--time", "obs_time", help="Observation time, ISO 8601: stars are rendered "
              "where they appear from the moving Earth (annual aberration).")
def simulate(config_path, sky, mag_limit, count, seed, out_dir, attitude, false_stars,
             missing, mag_noise, rate, fps, profile_path, write_fits_too, camera_path,
             overwrite, obs_time) -> None:
    """Render frames of a sky, with truth.csv, stars.csv and a JSON sidecar per frame.
    --out must be empty or new (or give --overwrite); frames are at most
    STARTRACK_MAX_IMAGE_PIXELS (default 8192 x 8192).
    Conventions (pixels, attitude, sidecar units): docs/conventions.md."""
    cfg = load_config(config_path) if config_path else config_from_dict(DEFAULT_CONFIG,
                                                                        "default config")
    camera = load_camera(camera_path) if camera_path else cfg.camera
    check_pixels(camera.width, camera.height,
                 camera_path or (f"{config_path} [camera]" if config_path else "camera"))
    spec = cfg.sky
    if sky is not None:
        spec = dataclasses.replace(spec, kind=sky)
    if mag_limit is not None:
        spec = dataclasses.replace(spec, mag_limit=mag_limit)
    spec = resolve_sky(spec, camera)
    given = dict(count=count, seed=seed, false_stars=false_stars, missing=missing,
                 mag_noise=mag_noise, rate_dps=rate)
    opts = dataclasses.replace(cfg.frames, **{k: v for k, v in given.items() if v is not None})
    trajectory = _trajectory(attitude, opts, fps, profile_path, count)
    if trajectory is not None:
        opts = dataclasses.replace(opts, count=len(trajectory))
    if obs_time is not None:
        from startrack.aberration import parse_time

        obs_time = parse_time(obs_time)
    out = Path(out_dir)
    check_out_folder(out, overwrite)
    try:
        _run(camera, spec, cfg.sensor, opts, out, attitude, write_fits_too, trajectory,
             obs_time)
    except OSError as exc:  # every file is atomic, so nothing half-written is left behind
        raise InputError(f"{out}: cannot write output ({exc.strerror or exc})") from None
    click.echo(f"wrote {opts.count} frame(s) to {out}/ (truth.csv, stars.csv, "
               f"frame_*.png{', frame_*.fits' if write_fits_too else ''}, frame_*.json)")


TRUTH_HEADER = ["frame", "file", "qw", "qx", "qy", "qz", "ra_deg", "dec_deg", "roll_deg"]
STARS_HEADER = ["frame", "x", "y", "flux", "magnitude", "catalog_id", "is_false"]
BLOCK = 256  # sequence attitudes computed this many frames at a time (bounded memory)


def _run(camera: Camera, spec: SkySpec, sensor: SensorModel, opts: FrameOptions, out: Path,
         attitude: tuple[float, float, float] | None, with_fits: bool,
         trajectory=None, obs_time=None) -> int:
    """Render the frames one at a time, each written as soon as it is made, its rows
    appended to truth.csv and stars.csv (which appear, complete, at the end). Stopped by
    SIGINT or SIGTERM, the frames written so far are kept and listed; the frame in the
    making is removed. Returns the number of frames written."""
    from tqdm import tqdm

    from startrack.sky import load_sky

    # Before any output, so that a bad sky leaves no files.
    catalog = _apparent(load_sky(spec, camera), obs_time)
    remove_own(out, OWN_FILES)  # an earlier run's frames must not outlive it (--overwrite)
    frame = _FrameWriter(camera, spec, sensor, opts, out, attitude, with_fits, trajectory,
                         obs_time, catalog)
    done = 0
    stopped: BaseException | None = None
    with atomic_text(out / "truth.csv") as truth_fh, atomic_text(out / "stars.csv") as stars_fh:
        truth, stars = csv.writer(truth_fh, lineterminator="\n"), csv.writer(
            stars_fh, lineterminator="\n")
        truth.writerow(TRUTH_HEADER)
        stars.writerow(STARS_HEADER)
        bar = tqdm(range(opts.count), file=sys.stderr, unit="frame", desc="simulate",
                   disable=not sys.stderr.isatty())
        try:
            for i in bar:
                truth_row, star_rows = frame.write(i)
                truth.writerow(truth_row)
                stars.writerows(star_rows)
                done = i + 1
                if i == 0:
                    _check_disk(out, frame.files(0), opts.count)
        except (KeyboardInterrupt, Terminated) as exc:  # keep what is complete
            frame.remove(done)
            stopped = exc
        except BaseException:  # an error: truth.csv will not appear, so neither do frames
            for k in range(done + 1):
                frame.remove(k)
            raise
    if stopped is not None:
        click.echo(f"simulate: stopped after {done} frame(s); truth.csv and stars.csv list "
                   "them", err=True)
        raise stopped
    return done


class _FrameWriter:
    """Renders and writes frame i (image, FITS, sidecar) and gives its CSV rows."""

    def __init__(self, camera, spec, sensor, opts, out, attitude, with_fits, trajectory,
                 obs_time, catalog) -> None:
        from startrack.attitude import from_radec_roll

        self.camera, self.spec, self.sensor, self.opts = camera, spec, sensor, opts
        self.out, self.with_fits, self.trajectory = out, with_fits, trajectory
        self.catalog = catalog
        self.when = None if obs_time is None else obs_time.utc.isot
        self.fixed = from_radec_roll(*attitude) if attitude is not None else None
        self._block: tuple[int, object] | None = None

    def files(self, i: int) -> list[Path]:
        png = self.out / f"frame_{i:04d}.png"
        return [png, self.out / f"frame_{i:04d}.fits", sidecar_path_for(png)]

    def remove(self, i: int) -> None:
        for path in self.files(i):
            path.unlink(missing_ok=True)

    def _pose(self, i: int, rng):
        """Frame i's attitude and rate: the sequence's (--fps), else fixed or random."""
        if self.trajectory is None:
            return (self.fixed if self.fixed is not None else _random_rotation(rng),
                    self.opts.rate_dps)
        if self._block is None or not 0 <= i - self._block[0] < BLOCK:
            self._block = (i, self.trajectory.block(i, BLOCK))
        k = i - self._block[0]
        block = self._block[1]
        return block.rotations[k], tuple(float(w) for w in block.rates_dps[k])

    def write(self, i: int) -> tuple[list, list[list]]:
        from startrack.attitude import to_quaternion, to_radec_roll
        from startrack.imageio import write_fits, write_png16
        from startrack.render import render_frame
        from startrack.scene import observe
        from startrack.wcs import wcs_header

        opts, camera, sensor = self.opts, self.camera, self.sensor
        rng = np.random.default_rng([opts.seed, i])  # each frame reproducible on its own
        rotation, rate_dps = self._pose(i, rng)
        scene = observe(self.catalog, camera, rotation, rng, missing=opts.missing,
                        false_stars=opts.false_stars, mag_noise=opts.mag_noise,
                        hot_pixel_fraction=opts.hot_pixel_fraction)
        image = render_frame(scene, camera, sensor, rng, angular_rate_dps=rate_dps)
        png, fits_path, sidecar_path = self.files(i)
        write_png16(png, image)
        if self.with_fits:
            write_fits(fits_path, image, wcs_header(
                camera, rotation, date_obs=self.when,
                extra=_fits_keywords(sensor, png.name)))
        q = [float(c) for c in to_quaternion(rotation)]
        ra, dec, roll = to_radec_roll(rotation)
        sidecar = {
            "image": png.name, "frame": i, "seed": opts.seed,
            "units": SIDECAR_UNITS,
            "camera": camera.to_dict(), "sky": _sky_entry(self.spec),
            "attitude": {"quaternion": q, "ra_deg": ra, "dec_deg": dec, "roll_deg": roll},
            "sensor": sensor.to_dict(), "time_utc": self.when,
            "frames": {"missing": opts.missing, "false_stars": opts.false_stars,
                       "mag_noise": opts.mag_noise, "rate_dps": rate_dps},
        }
        if self.trajectory is not None:
            sidecar["time_s"] = float(i / self.trajectory.fps)
        with atomic_text(sidecar_path) as fh:
            json.dump(sidecar, fh, indent=2)
            fh.write("\n")
        flux = sensor.electrons_from_mag(scene.mag)
        # a few dozen rows per frame, for the CSV writer (ids stay exact integers)
        columns = (scene.x, scene.y, flux, scene.mag, scene.catalog_id,
                   np.asarray(scene.is_false, dtype=np.int64))
        stars = [[i, *row] for row in zip(*(np.asarray(c).tolist() for c in columns),
                                          strict=True)]
        return [i, png.name, *q, ra, dec, roll], stars


def _check_disk(out: Path, first_files: list[Path], count: int) -> None:
    """Refuse, after the first frame, a run whose frames cannot fit the free space."""
    import shutil

    per_frame = sum(p.stat().st_size for p in first_files if p.exists()) + 4096
    need = per_frame * (count - 1)
    free = shutil.disk_usage(out).free
    if need > free * 0.95:
        raise InputError(f"{out}: {count:,} frames need about {need / 1e9:.3g} GB "
                         f"({per_frame / 1e6:.3g} MB a frame) but only {free / 1e9:.3g} GB "
                         "is free; give fewer --frames")


def _trajectory(attitude, opts: FrameOptions, fps, profile_path, count):
    """The sequence's attitudes (startrack.trajectory), None for independent frames."""
    from startrack.attitude import from_radec_roll
    from startrack.trajectory import simulation_trajectory

    start = (from_radec_roll(*attitude) if attitude is not None
             else _random_rotation(np.random.default_rng([opts.seed, 1 << 20])))
    return simulation_trajectory(start, opts.rate_dps, fps, profile_path, count)


#: what the numbers in a sidecar are measured in (docs/conventions.md)
SIDECAR_UNITS = {
    "pixels": "px; (0, 0) is the centre of the top-left pixel, x right, y down",
    "angles": "deg (fov_deg, ra_deg, dec_deg, roll_deg, min_separation_deg)",
    "quaternion": "scalar first [w, x, y, z], camera frame to ICRS",
    "rate_dps": "deg/s about the camera axes",
    "magnitudes": "catalog magnitudes (Hipparcos Hp for the Hipparcos sky)",
    "sensor": "electrons (e-), ADU counts, seconds; gain in e-/ADU",
}


def _sky_entry(spec: SkySpec) -> dict:
    """The sky as a sidecar records it: a random sky's size and seed, only for one."""
    entry = spec.to_dict()
    if spec.kind != "random":
        entry.pop("n_stars", None)
        entry.pop("seed", None)
    return entry


def _apparent(catalog, obs_time):
    """The catalog as seen from the Earth at ``obs_time`` (unchanged without a time)."""
    if obs_time is None:
        return catalog
    from startrack.aberration import apparent_catalog

    return apparent_catalog(catalog, obs_time)


def _fits_keywords(sensor: SensorModel, png_name: str) -> dict:
    return {"EXPTIME": (sensor.exposure_s, "[s] exposure time"),
            "GAIN": (sensor.gain, "[e-/ADU] detector gain"),
            "BUNIT": ("adu", "pixel values are detector counts (ADU)"),
            "FRAME": (png_name, "the same frame as PNG")}


def _random_rotation(rng: np.random.Generator):
    from startrack.attitude import random_attitudes

    return random_attitudes(1, rng)[0]
