"""`startrack compare`: a Monte Carlo comparison of identification methods.

With no options it runs the 2011 paper's experiment: a random 2000-star sky, a 17.5 deg
1024 x 1024 camera, patterns from the five brightest stars, methods angle, triangle and
hybrid, against centroid noise and false stars.
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import click

from startrack.bench import SOURCES
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
from startrack.cli._compare_request import (
    DEFAULT_LEVELS,
    CompareRequest,
    CompareRun,
    condition_levels,
)
from startrack.cli._effect_options import colour_levels_option, effect_levels_options
from startrack.cli._shared_options import (
    SKY_HELP,
    SKY_NAME,
    Number,
    index_dir_option,
    notes,
    verbosity,
)
from startrack.errors import InputError
from startrack.input_checks import (
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


def _sky(cfg, sky: str | None, mag_limit: float | None):
    """The config's sky with the options applied and its defaults resolved."""
    from startrack.sky import resolve_sky, with_sky  # scipy.spatial: when the command runs

    spec_sky = cfg.sky if sky is None else with_sky(cfg.sky, sky)
    if mag_limit is not None:
        spec_sky = dataclasses.replace(spec_sky, mag_limit=mag_limit)
    return resolve_sky(spec_sky, cfg.camera)


def _check_image_size(cfg, config_path) -> None:
    from startrack.io import check_pixels

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
    from startrack.simulate import DEFAULT_CONFIG, config_from_dict, load_config

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
@colour_levels_option
@verbosity
def compare(**given) -> None:
    """Compare identification methods on the same frames (random ones, or --frames-dir)
    under centroid noise, false and missing stars, a wrong camera (FOV error, distortion)
    and, on rendered frames, sensor and space effects (docs/simulation.md).

    Writes frames.csv, summary.csv, db.csv, plots and report.md in --out; their columns
    and the other conventions are in docs/conventions.md. Progress goes to stderr: a bar
    on a terminal, a line every few seconds otherwise (-q: none)."""
    request = CompareRequest.from_options(given)
    names = parse_methods(request.methods)
    note, detail = notes(request.quiet, request.verbose)
    reports: list = []
    finish = report_writer(click.get_current_context(), reports)
    out_dir, started = run_folder(request.folder.out_dir, request.folder.resume, note)
    run = CompareRun(request, names, Path(out_dir), note, detail, started, finish, reports)
    RUNNERS[request.run_mode](run)


def _setup(request: CompareRequest):
    """(config, its sky with the options applied, the files read) of a generated run."""
    cfg, inputs = _config(request.config_path)
    spec_sky = _sky(cfg, request.sky, request.mag_limit)
    if request.source == "images":  # frames are rendered at the camera's size
        _check_image_size(cfg, request.config_path)
    return cfg, spec_sky, inputs


def _tracking(run: CompareRun) -> None:
    """``--mode tracking``: frame sequences (startrack.bench's tracking bench)."""
    cfg, spec_sky, inputs = _setup(run.request)
    tracking_run(run, cfg, spec_sky, inputs)
    run.started()


def _spec(run: CompareRun):
    """(the lost-in-space run's spec, the files read): every method on the same frames of
    every condition."""
    request = run.request
    cfg, spec_sky, inputs = _setup(request)
    levels = condition_levels(request.levels, request.source, cfg.effects)
    spec = _run_spec(cfg, spec_sky, run.methods, levels, request.grid,
                     request.frames, request.seed, request.source, request.max_stars,
                     request.threshold_arcsec)
    return spec, inputs


def _replay(run: CompareRun) -> None:
    """``--replay CONDITION,FRAME``: one unit through every method, printed."""
    replay_one(_spec(run)[0], run.request.replay)


def _lost_in_space(run: CompareRun) -> None:
    """The Monte Carlo run: every method on every condition's frames, with resume."""
    from startrack.bench import run_comparison

    request = run.request
    spec, inputs = _spec(run)
    jobs, n_units = _workers(request.jobs), len(spec.conditions) * request.frames
    scheduler = request.scheduler
    where = f"Dask at {scheduler}" if scheduler else f"{jobs} process(es)"

    def announce() -> None:
        run.started()
        run.note(f"compare: {', '.join(run.methods)} on {len(spec.conditions)} condition(s) "
                 f"x {request.frames} frame(s) from {request.source} ({n_units} units, "
                 f"{where})")
        for k, condition in enumerate(spec.conditions):
            run.detail(f"  condition {k}: {condition.to_dict()}")

    try:
        result = run_comparison(spec, run.out_dir, jobs=jobs, scheduler=scheduler,
                                resume=request.folder.resume, progress=not request.quiet,
                                announce=announce, overwrite=request.folder.overwrite,
                                inputs=inputs, finish=run.finish)
    except InputError:
        raise
    except OSError as exc:  # every file is atomic or resumable: nothing is left torn
        raise InputError(f"--out {run.out_dir}: cannot write ({exc.strerror or exc})") \
            from None
    if result.units_resumed:
        run.note(f"resumed: {result.units_resumed} unit(s) were already done")
    print_finished(result, run.reports[0])


#: one runner per mode (:attr:`CompareRequest.run_mode`)
RUNNERS = {"frames_dir": frames_dir_run, "tracking": _tracking, "replay": _replay,
           "lost_in_space": _lost_in_space}


def _run_spec(cfg, spec_sky, names, levels, grid, frames, seed, source, max_stars,
              threshold_arcsec):
    """The lost-in-space run: every method on the same frames of every condition."""
    from startrack.bench import RunSpec, build_conditions

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
