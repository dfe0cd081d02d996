"""`startrack compare`: a Monte Carlo comparison of identification methods.

With no options it runs the 2011 paper's experiment: a random 2000-star sky, a 17.5 deg
1024 x 1024 camera, patterns from the five brightest stars, methods angle, triangle and
hybrid, against centroid noise and false stars.
"""

from __future__ import annotations

import dataclasses
import os

import click

from startrack.bench.conditions import SOURCES
from startrack.cli import main
from startrack.cli._compare_modes import (
    RUNS_FOLDER,
    frames_dir_run,
    print_finished,
    replay_one,
    report_writer,
    run_folder,
    tracking_run,
)
from startrack.cli.effect_options import effect_levels_options
from startrack.cli.options import SKY_HELP, SKY_NAME, Number, index_dir_option, notes, verbosity
from startrack.errors import InputError
from startrack.validate import (
    FALSE_STARS,
    FPS,
    FRAMES,
    JOBS,
    MAG_LIMIT,
    MAX_STARS,
    SEED,
    THRESHOLD_ARCSEC,
)

DEFAULT_OUT = RUNS_FOLDER  # each run without --out: a new folder in it
DEFAULT_METHODS = "angle,triangle,hybrid"
# Chosen so the default run (7 conditions x 3 methods) takes about a minute on 2 cores:
# measured, its 7000 units cost ~70 s of CPU, i.e. ~40 s on 2 idle cores (more on a
# loaded machine). 1000 frames put a 95% rate within about +-1.4%.
DEFAULT_FRAMES = 1000
MAX_UNITS = 10_000_000  # frames x conditions of one run (docs/limits.md)
DEFAULT_LEVELS = {"noise_px": "0,0.5,1,2", "false_stars": "0,1,3,5", "missing": "0",
                  "mag_noise": "0", "fov_error": "0", "distortion_k1": "0",
                  "modelled_k1": "0"}


def parse_methods(text: str) -> tuple[str, ...]:
    """A comma-separated list of registered method names, without repeats."""
    from startrack.matchers import get_matcher

    names = [p.strip() for p in text.split(",")]
    if not names or any(not n for n in names):
        raise InputError(f"--methods: expected a comma-separated list of names, got {text!r}")
    if len(set(names)) != len(names):
        raise InputError(f"--methods: repeated method in {text!r}")
    for name in names:
        get_matcher(name)  # raises InputError naming the choices
    return tuple(names)


def _effect_levels(given: tuple, effects, source: str) -> dict[str, tuple]:
    """The effect axes' levels from the options' texts (``given``, in EFFECT_OPTIONS'
    order), else the config's one level; an effect needs rendered frames."""
    from startrack.bench.conditions import is_default, parse_values
    from startrack.cli.effect_options import EFFECT_OPTIONS, effect_bounds

    config = {"cosmic_rays": effects.environment.cosmic_rays,
              "stray_light": effects.environment.stray_light,
              "temperature_c": effects.detector.temperature_c}
    levels = {}
    for (option, param, *_), text in zip(EFFECT_OPTIONS, given, strict=True):
        bounds = effect_bounds(param)
        levels[param] = (parse_values(text, option, low=bounds.low, high=bounds.high)
                         if text is not None else (config[param],))
        if source != "images" and any(not is_default(param, v) for v in levels[param]):
            raise InputError(f"{option} acts on rendered frames: give --from images")
    return levels


def _levels(noise_px, false_stars, missing, mag_noise, source: str,
            camera_levels: dict | None = None) -> dict[str, tuple]:
    from startrack.bench.conditions import parse_values

    if source == "images":
        if noise_px is not None:
            click.echo("note: --noise-px does not apply to --from images (the sensor model "
                       "sets the pixel noise); ignored", err=True)
        noise_px = "0"
    given = {"noise_px": noise_px, "false_stars": false_stars, "missing": missing,
             "mag_noise": mag_noise, "fov_error": None, "distortion_k1": None,
             "modelled_k1": None, **(camera_levels or {})}
    text = {k: DEFAULT_LEVELS[k] if v is None else v for k, v in given.items()}
    return {
        "noise_px": parse_values(text["noise_px"], "--noise-px"),
        "false_stars": parse_values(text["false_stars"], "--false-stars", integer=True,
                                     high=FALSE_STARS.high),
        "missing": parse_values(text["missing"], "--missing", high=1.0),
        "mag_noise": parse_values(text["mag_noise"], "--mag-noise"),
        "fov_error": parse_values(text["fov_error"], "--fov-error", low=-0.5, high=0.5),
        "distortion_k1": parse_values(text["distortion_k1"], "--distortion", low=-1.0,
                                      high=1.0),
        "modelled_k1": parse_values(text["modelled_k1"], "--modelled-distortion", low=-1.0,
                                    high=1.0),
    }


def _sky(cfg, sky: str | None, mag_limit: float | None):
    """The config's sky with the options applied and its defaults resolved."""
    from startrack.sky import resolve_sky, with_sky  # scipy.spatial: when the command runs

    spec_sky = cfg.sky if sky is None else with_sky(cfg.sky, sky)
    if mag_limit is not None:
        spec_sky = dataclasses.replace(spec_sky, mag_limit=mag_limit)
    return resolve_sky(spec_sky, cfg.camera)


def _check_image_size(cfg, config_path) -> None:
    from startrack.io._headers import check_pixels

    check_pixels(cfg.camera.width, cfg.camera.height, f"{config_path or 'config'} [camera]")


def _workers(jobs: int | None) -> int:
    """--jobs, at most the number of CPUs (each worker holds a database: more only add
    memory), with a note when capped."""
    cores = os.cpu_count() or 1
    if jobs is not None and jobs > cores:
        click.echo(f"note: --jobs {jobs} is more than the {cores} CPU(s); using {cores}",
                   err=True)
    return min(jobs or cores, cores)


def _config(config_path):
    """The run's configuration (the file's, else the default) and the input files it read."""
    from startrack.simulate._config import DEFAULT_CONFIG, config_from_dict, load_config

    if config_path:
        return load_config(config_path), [config_path]
    return config_from_dict(DEFAULT_CONFIG, "default config"), []


@main.command()
@click.option("--methods", default=DEFAULT_METHODS, show_default=True,
              help="Comma-separated methods to compare.")
@click.option("--config", "config_path", type=click.Path(dir_okay=False),
              help="TOML preset (configs/); default: configs/paper2011.toml's setup.")
@click.option("--sky", type=SKY_NAME, help=f"{SKY_HELP} Overrides the config.")
@index_dir_option
@click.option("--mag-limit", type=Number(MAG_LIMIT), help="Faintest catalog magnitude to use.")
@click.option("--frames", type=Number(FRAMES), default=DEFAULT_FRAMES, show_default=True,
              help="Frames per condition.")
@click.option("--noise-px", help="Centroid noise levels, px (first = base) "
              f"[default: {DEFAULT_LEVELS['noise_px']}].")
@click.option("--false-stars", help="False stars per frame (first = base) "
              f"[default: {DEFAULT_LEVELS['false_stars']}].")
@click.option("--missing", help="Star dropout fractions (first = base) [default: 0].")
@click.option("--mag-noise", help="Magnitude noise levels (first = base) [default: 0].")
@click.option("--fov-error", help="Fractional errors of the FOV the methods are told, e.g. "
              "0,0.02,-0.05 (first = base) [default: 0].")
@click.option("--distortion", "distortion_k1", help="Radial k1 of the frames' lens, not "
              "told to the methods, e.g. 0,-0.05 (first = base) [default: 0].")
@click.option("--modelled-distortion", "modelled_k1", help="Radial k1 of the frames' lens, "
              "given to the methods in their camera model (first = base) [default: 0].")
@click.option("--grid", type=click.Choice(["oat", "full"]), default="oat", show_default=True,
              help="oat: vary one variable at a time around the base; full: every "
              "combination.")
@click.option("--max-stars", type=Number(MAX_STARS), default=5, show_default=True,
              help="Brightest stars a method may use to form patterns.")
@click.option("--from", "source", type=click.Choice(SOURCES), default="centroids",
              show_default=True, help="centroids: perturb true positions (fast); images: "
              "render, extract centroids and match (the full pipeline).")
@click.option("--threshold-arcsec", type=Number(THRESHOLD_ARCSEC), default=60.0, show_default=True,
              help="Pointing error up to which a solution counts as correct (or 5 sigma of "
              "the centroid noise if larger).")
@click.option("--jobs", type=Number(JOBS), default=None,
              help="Local worker processes [default, and at most: the number of CPUs].")
@click.option("--scheduler", help="Dask scheduler address (needs startrack[dask]).")
@click.option("--out", "out_dir", type=click.Path(file_okay=False),
              help=f"Output folder [default: a new {DEFAULT_OUT}/<date>-<time>/ (UTC) for "
              f"each run, {DEFAULT_OUT}/latest pointing at the newest].")
@click.option("--seed", type=Number(SEED), default=None, help="Seed of the frames [default: the "
              "config's [frames] seed, 0].")
@click.option("--resume/--no-resume", default=None,
              help="Continue the run in --out (without --out: the latest run) or start "
              "over. With --out and neither, a matching run there is continued and a "
              "different one refused; without --out every run is new.")
@click.option("--overwrite", is_flag=True,
              help="Use an --out that holds files startrack did not write (they are kept "
              "and never replaced; a folder of a simulate run is refused; "
              "docs/conventions.md).")
@click.option("--mode", type=click.Choice(["lost_in_space", "tracking"]),
              default="lost_in_space", show_default=True,
              help="tracking: frame sequences solved frame after frame (each matcher "
              "tracked and alone, tetra3rs's attitude_hint where installed); --frames is "
              "then the frames per sequence [default 100], --methods the fallback matchers "
              "[default pyramid].")
@click.option("--rates", help="Tracking mode: rate magnitudes in deg/s along (1, 0.5, 2) "
              "(first = base) [default: 2.2913,0,1,5,10].")
@click.option("--fps", type=Number(FPS), default=10.0, show_default=True,
              help="Tracking mode: frames per second.")
@click.option("--replay", metavar="CONDITION,FRAME",
              help="Rerun one frame of this run through every method and print each answer "
              "(report.md lists the command for every failed frame); writes nothing.")
@click.option("--frames-dir", type=click.Path(file_okay=False),
              help="Run every method on this folder's frames (images or centroid CSVs) "
              "instead of generated ones, scored against its truth.csv, stars.csv and "
              "sidecars (the format simulate writes); the levels options do not apply.")
@effect_levels_options
@verbosity
def compare(methods, config_path, sky, mag_limit, frames, noise_px, false_stars, missing,
            mag_noise, fov_error, distortion_k1, modelled_k1, grid, max_stars, source,
            threshold_arcsec, jobs, scheduler, out_dir, seed, resume, overwrite, mode, rates,
            fps, replay, frames_dir, cosmic_rays, stray_light, temperature_c, quiet,
            verbose) -> None:
    """Compare identification methods on the same frames (random ones, or --frames-dir)
    under centroid noise, false and missing stars, a wrong camera (FOV error, distortion)
    and, on rendered frames, sensor and space effects (docs/simulation.md).

    Writes frames.csv, summary.csv, db.csv, plots and report.md in --out; their columns
    and the other conventions are in docs/conventions.md. Progress goes to stderr: a bar
    on a terminal, a line every few seconds otherwise (-q: none)."""
    from startrack.bench.session import run_comparison

    names = parse_methods(methods)
    note, detail = notes(quiet, verbose)
    finish = report_writer(click.get_current_context(), reports := [])
    out_dir, started = run_folder(out_dir, resume, note)
    if frames_dir is not None:
        return frames_dir_run(frames_dir, names, out_dir, max_stars, threshold_arcsec, quiet,
                              note, overwrite, finish, reports, started)
    cfg, inputs = _config(config_path)
    spec_sky = _sky(cfg, sky, mag_limit)
    if source == "images":  # frames are rendered at the camera's size
        _check_image_size(cfg, config_path)
    if mode == "tracking":  # frame sequences (startrack.bench.tracking_report)
        tracking_run(cfg, spec_sky, names, frames, rates, noise_px, false_stars,
                     missing, fps, seed, out_dir, threshold_arcsec, note,
                     dict(resume=resume, overwrite=overwrite, inputs=inputs))
        return started()
    levels = _levels(noise_px, false_stars, missing, mag_noise, source, dict(
        fov_error=fov_error, distortion_k1=distortion_k1, modelled_k1=modelled_k1)) | \
        _effect_levels((cosmic_rays, stray_light, temperature_c), cfg.effects, source)
    spec = _run_spec(cfg, spec_sky, names, levels, grid, frames, seed, source, max_stars,
                     threshold_arcsec)
    if replay is not None:
        replay_one(spec, replay)
        return
    jobs, n_units = _workers(jobs), len(spec.conditions) * frames
    where = f"Dask at {scheduler}" if scheduler else f"{jobs} process(es)"

    def announce() -> None:
        started()
        note(f"compare: {', '.join(names)} on {len(spec.conditions)} condition(s) x "
             f"{frames} frame(s) from {source} ({n_units} units, {where})")
        for k, condition in enumerate(spec.conditions):
            detail(f"  condition {k}: {condition.to_dict()}")

    try:
        result = run_comparison(spec, out_dir, jobs=jobs, scheduler=scheduler, resume=resume,
                                progress=not quiet, announce=announce,
                                overwrite=overwrite, inputs=inputs, finish=finish)
    except InputError:
        raise
    except OSError as exc:  # every file is atomic or resumable: nothing is left torn
        raise InputError(f"--out {out_dir}: cannot write ({exc.strerror or exc})") from None
    if result.units_resumed:
        note(f"resumed: {result.units_resumed} unit(s) were already done")
    print_finished(result, reports[0])


def _run_spec(cfg, spec_sky, names, levels, grid, frames, seed, source, max_stars,
              threshold_arcsec):
    """The lost-in-space run: every method on the same frames of every condition."""
    from startrack.bench.conditions import build_conditions
    from startrack.bench.runner import RunSpec

    conditions = tuple(build_conditions(levels, grid))
    n_units = len(conditions) * frames
    if n_units > MAX_UNITS:  # the run's unit list alone would not fit in memory
        raise InputError(f"--frames {frames} x {len(conditions)} condition(s) is "
                         f"{n_units:,} units, above the limit of {MAX_UNITS:,}")
    return RunSpec(
        methods=names, conditions=conditions, frames=frames,
        seed=cfg.frames.seed if seed is None else seed, camera=cfg.camera, sky=spec_sky,
        sensor=cfg.sensor, source=source, grid=grid, max_stars=max_stars,
        hot_pixel_fraction=cfg.frames.hot_pixel_fraction, threshold_arcsec=threshold_arcsec,
        effects=cfg.effects)

__all__ = [
    "DEFAULT_FRAMES", "DEFAULT_LEVELS", "DEFAULT_METHODS", "DEFAULT_OUT", "MAX_UNITS",
    "compare", "parse_methods",
]
