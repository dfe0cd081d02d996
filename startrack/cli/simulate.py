"""`startrack simulate`: render CCD frames of a sky with the truth beside each frame."""

from __future__ import annotations

import csv
import dataclasses
import sys
from pathlib import Path

import click
import numpy as np

from startrack.cache import atomic_text
from startrack.camera import Camera
from startrack.camera_file import load_camera
from startrack.cli import Terminated, main
from startrack.cli.options import Number, triple
from startrack.cli.simulate_frames import FrameWriter, check_disk, random_rotation
from startrack.config import DEFAULT_CONFIG, FrameOptions, config_from_dict, load_config
from startrack.errors import InputError
from startrack.image_header import check_pixels
from startrack.outputs import check_out_folder, remove_own
from startrack.sensor import SensorModel
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
    frame = FrameWriter(camera, spec, sensor, opts, out, attitude, with_fits, trajectory,
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
                    check_disk(out, frame.files(0), opts.count)
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


def _trajectory(attitude, opts: FrameOptions, fps, profile_path, count):
    """The sequence's attitudes (startrack.trajectory), None for independent frames."""
    from startrack.attitude import from_radec_roll
    from startrack.trajectory import simulation_trajectory

    start = (from_radec_roll(*attitude) if attitude is not None
             else random_rotation(np.random.default_rng([opts.seed, 1 << 20])))
    return simulation_trajectory(start, opts.rate_dps, fps, profile_path, count)


def _apparent(catalog, obs_time):
    """The catalog as seen from the Earth at ``obs_time`` (unchanged without a time)."""
    if obs_time is None:
        return catalog
    from startrack.aberration import apparent_catalog

    return apparent_catalog(catalog, obs_time)
