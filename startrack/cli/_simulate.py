"""`startrack simulate`: render CCD frames of a sky with the truth beside each frame."""

from __future__ import annotations

import csv
import dataclasses
from pathlib import Path
from typing import TYPE_CHECKING

import click
import numpy as np

from startrack.cli import Terminated, main
from startrack.cli._effect_options import effect_options
from startrack.cli._shared_options import (
    SKY_HELP,
    SKY_NAME,
    Number,
    index_dir_option,
    notes,
    triple,
    verbosity,
)
from startrack.errors import InputError
from startrack.input_checks import (
    FALSE_STARS,
    FPS,
    FRACTION,
    FRAMES,
    MAG_LIMIT,
    MAG_NOISE,
    RATE_DPS,
    SEED,
)
from startrack.io import RunFolder, atomic_text, check_pixels
from startrack.simulate import SensorModel

if TYPE_CHECKING:  # the camera loads the compiled core: only when a command runs
    from startrack.camera import Camera
    from startrack.simulate import FrameOptions
    from startrack.sky import SkySpec

DEFAULT_OUT = Path("out/simulate")
#: the names simulate writes in --out
SIMULATE_OUTPUTS = r"truth\.csv|stars\.csv|frame_\d{4,}\.(png|fits|json)"


@main.command()
@click.option("--config", "config_path", type=click.Path(dir_okay=False),
              help="TOML preset: a file, or a shipped preset by name (hipparcos20, "
                   "paper2011, radial_triangles, realsky); default: the 2011 paper's experiment.")
@click.option("--sky", type=SKY_NAME, help=f"{SKY_HELP} Overrides the config.")
@index_dir_option
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
              help="Write into a used --out: first remove the files an earlier simulate "
                   "listed there (.startrack-files); files startrack did not write are kept "
                   "and never replaced, and another command's run is refused.")
@click.option("--time", "obs_time", help="Observation time, ISO 8601: stars are rendered "
              "where they appear from the moving Earth (annual aberration).")
@effect_options
@verbosity
def simulate(config_path, sky, mag_limit, count, seed, out_dir, attitude, false_stars,
             missing, mag_noise, rate, fps, profile_path, write_fits_too, camera_path,
             overwrite, obs_time, cosmic_rays, stray_light, temperature_c, quiet,
             verbose) -> None:
    """Render frames of a sky, with truth.csv, stars.csv and a JSON sidecar per frame.
    --out must be empty or new (or give --overwrite); frames are at most
    STARTRACK_MAX_IMAGE_PIXELS (default 8192 x 8192).
    Conventions (pixels, attitude, sidecar units): docs/conventions.md; the optics,
    detector and space effects (config tables, the options below): docs/simulation.md."""
    # scipy.spatial (startrack.sky, its rotations) loads only when the command runs.
    from startrack.simulate import DEFAULT_CONFIG, config_from_dict, load_config
    from startrack.sky import load_sky, resolve_sky, with_sky

    cfg = load_config(config_path) if config_path else config_from_dict(DEFAULT_CONFIG,
                                                                        "default config")
    # the camera (and the compiled core under it) loads only when a command runs
    from startrack.camera import load_camera
    camera = load_camera(camera_path) if camera_path else cfg.camera
    check_pixels(camera.width, camera.height,
                 camera_path or (f"{config_path} [camera]" if config_path else "camera"))
    spec = cfg.sky
    if sky is not None:
        spec = with_sky(spec, sky)
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
        from startrack.solver import parse_time

        obs_time = parse_time(obs_time)
    out = Path(out_dir)
    folder = RunFolder(out, "simulate", [p for p in (config_path, camera_path, profile_path)
                                         if p], overwrite=overwrite, reuse=False,
                       outputs=SIMULATE_OUTPUTS)
    folder.check()
    catalog = _apparent(load_sky(spec, camera), obs_time)  # a bad sky leaves no files
    try:
        with folder:
            _run(camera, catalog, spec, cfg.sensor, opts, folder, attitude, write_fits_too,
                 trajectory, obs_time, quiet, notes(quiet, verbose)[1],
                 cfg.effects.with_levels(cosmic_rays=cosmic_rays, stray_light=stray_light,
                                         temperature_c=temperature_c))
    except InputError:
        raise
    except OSError as exc:  # every file is atomic, so nothing half-written is left behind
        raise InputError(f"{out}: cannot write output ({exc.strerror or exc})") from None
    click.echo(f"wrote {opts.count} frame(s) to {out}/ (truth.csv, stars.csv, "
               f"frame_*.png{', frame_*.fits' if write_fits_too else ''}, frame_*.json)")


def _run(camera: Camera, catalog, spec: SkySpec, sensor: SensorModel, opts: FrameOptions,
         folder: RunFolder, attitude: tuple[float, float, float] | None, with_fits: bool,
         trajectory=None, obs_time=None, quiet: bool = False, detail=None,
         effects=None) -> int:
    """Render the frames one at a time, each written as soon as it is made, its rows
    appended to truth.csv and stars.csv (which appear, complete, at the end). Stopped by
    SIGINT or SIGTERM, the frames written so far are kept and listed; the frame in the
    making is removed. Returns the number of frames written."""
    from startrack.cli._simulate_frames import FrameWriter, check_disk  # the compiled core
    from startrack.io import STARS_COLUMNS, TRUTH_COLUMNS
    from startrack.outputs import iterate

    folder.remove_earlier()  # an earlier run's frames must not outlive it (--overwrite)
    out = folder.out
    frame = FrameWriter(camera, spec, sensor, opts, out, attitude, with_fits, trajectory,
                        obs_time, catalog, effects)
    done = 0
    stopped: BaseException | None = None
    with atomic_text(out / "truth.csv") as truth_fh, atomic_text(out / "stars.csv") as stars_fh:
        truth, stars = csv.writer(truth_fh, lineterminator="\n"), csv.writer(
            stars_fh, lineterminator="\n")
        truth.writerow(TRUTH_COLUMNS)
        stars.writerow(STARS_COLUMNS)
        try:
            for i in iterate(range(opts.count), desc="simulate", unit="frame", quiet=quiet):
                truth_row, star_rows = frame.write(i)
                truth.writerow(truth_row)
                stars.writerows(star_rows)
                done = i + 1
                if detail is not None:
                    ra, dec, roll = truth_row[-3:]
                    detail(f"{truth_row[1]}: RA {ra:.4f} Dec {dec:+.4f} roll {roll:.3f} deg, "
                           f"{len(star_rows)} spots")
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
    """The sequence's attitudes (startrack.simulate._trajectory), None for independent frames."""
    from startrack.attitude import from_radec_roll
    from startrack.cli._simulate_frames import random_rotation
    from startrack.simulate import simulation_trajectory

    start = (from_radec_roll(*attitude) if attitude is not None
             else random_rotation(np.random.default_rng([opts.seed, 1 << 20])))
    return simulation_trajectory(start, opts.rate_dps, fps, profile_path, count,
                                 opts.time_tag_error_s, opts.seed)


def _apparent(catalog, obs_time):
    """The catalog as seen from the Earth at ``obs_time`` (unchanged without a time)."""
    if obs_time is None:
        return catalog
    from startrack.solver import apparent_catalog

    return apparent_catalog(catalog, obs_time)

__all__ = ["DEFAULT_OUT", "simulate"]
