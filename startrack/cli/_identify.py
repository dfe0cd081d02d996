"""`startrack identify`: images or centroid CSVs in, attitude and star identities out."""

from __future__ import annotations

import contextlib
import sys
from dataclasses import dataclass, fields
from pathlib import Path
from typing import TYPE_CHECKING

import click

from startrack.centroids import DEFAULT_SIGMA_PX
from startrack.cli import main
from startrack.cli._hint_options import HINT_KEYS, hint_options, hints_from
from startrack.cli._identify_output import (
    NothingAnswered,
    around_bar,
    fov_suggestion,
    inputs_with_progress,
    record_writer,
    say_written,
    summary_line,
    verbose_notes,
)
from startrack.cli._shared_options import SKY_HELP, SKY_NAME, Number, index_dir_option, triple
from startrack.defaults import (
    BLIND_FOV_RANGE,
    BUILTIN_METHODS,
    DEFAULT_FOV_TOLERANCE,
    DEFAULT_METHOD,
    DEFAULT_PRIOR_SIGMA_DEG,
    DEFAULT_TIMEOUT_MS,
    GAIA_BELOW_FOV_DEG,
)
from startrack.errors import InputError
from startrack.io import Writer, guarded_stdout
from startrack.outputs import SideOutputs

if TYPE_CHECKING:
    from startrack.solver import Options

from startrack.input_checks import DOWNSAMPLE, IMAGE_SIDE_PX, SOLVER_BOUNDS, check_number


def _size(ctx, param, value):
    if value is None:
        return None
    try:
        w, h = (int(p) for p in value.lower().split("x"))
    except ValueError:
        raise click.BadParameter(f"expected WxH in pixels, e.g. 1024x768, got {value!r}") \
            from None
    return (int(check_number(w, "--size: width", IMAGE_SIDE_PX)),
            int(check_number(h, "--size: height", IMAGE_SIDE_PX)))


def _time(ctx, param, value):
    if value is None:
        return None
    from startrack.solver import parse_time

    return parse_time(value)


@main.command()
@click.argument("inputs", nargs=-1, required=True, type=click.Path(dir_okay=False))
@click.option("--camera", "camera_path", type=click.Path(dir_okay=False),
              help="Camera file (JSON or TOML, keys in docs/conventions.md).")
@click.option("--fov", "fov_deg", type=Number(SOLVER_BOUNDS["fov_deg"]),
              help="Horizontal field of view in degrees (image size from the image, or "
                   "--size for a CSV).")
@click.option("--fov-tolerance", type=Number(SOLVER_BOUNDS["fov_tolerance"]),
              default=DEFAULT_FOV_TOLERANCE, show_default=True,
              help="The true FOV may be this fraction above or below --fov (or the camera "
                   "file's); it is fitted and reported as fov_deg. 0: exactly as given. "
                   "With no FOV at all (no --fov, camera file or sidecar) a blind search "
                   f"covers {BLIND_FOV_RANGE[0]:g} to {BLIND_FOV_RANGE[1]:g} deg.")
@click.option("--size", callback=_size, help="Image size WxH for a centroid CSV with --fov.")
@click.option("--sky", type=SKY_NAME,
              help=f"{SKY_HELP} Default: the frame sidecar's sky, else hipparcos from "
                   f"{GAIA_BELOW_FOV_DEG:g} deg, gaia below it, tycho2 (when installed) "
                   "where gaia is too shallow or with no FOV (docs/conventions.md).")
@index_dir_option
@click.option("--mag-limit", type=Number(SOLVER_BOUNDS["mag_limit"]),
              help="Faintest catalog magnitude. Default for hipparcos: the faintest half "
                   "magnitude with <= 80 catalog stars in an average frame (20 deg -> 6.5, "
                   "11.4 deg -> 7.5).")
@click.option("--epoch", type=Number(SOLVER_BOUNDS["epoch"]),
              help="Julian year to carry Hipparcos positions to by proper motion "
                   "(default: the catalog epoch, J1991.25).")
@click.option("--time", "obs_time", callback=_time,
              help="Observation time, ISO 8601 (e.g. 2019-07-29T20:47:26Z; no offset = "
                   "UTC): the attitude is corrected for annual aberration (up to 20 "
                   "arcsec). Default: a FITS input's DATE-OBS plus half its EXPTIME, else no "
                   "correction.")
@click.option("--method", default=DEFAULT_METHOD, show_default=True,
              help=f"Matcher, one of: {', '.join(BUILTIN_METHODS)}, or a plugin's "
                   "(docs/results.md compares them).")
@click.option("--max-stars", type=Number(SOLVER_BOUNDS["max_stars"]),
              help="Brightest stars the matcher may use to form patterns.")
@click.option("--sigma-px", type=Number(SOLVER_BOUNDS["sigma_px"]),
              help="1-sigma centroid error in pixels; sets match tolerances. Default: "
                   f"{DEFAULT_SIGMA_PX} px, more for wide star images (a tenth of their "
                   "radius; the record's diagnostics give the value used).")
@click.option("--timeout-ms", type=Number(SOLVER_BOUNDS["timeout_ms"]),
              default=DEFAULT_TIMEOUT_MS, show_default=True,
              help="Wall-clock limit per input, over all its stages (the method, the FOV "
                   "refit and search; a first use's one-time table builds not counted); "
                   "past it the input is not solved, with reason timeout in its record "
                   "(docs/limits.md).")
@click.option("--format", "fmt", type=click.Choice(["table", "json", "csv"]), default="table",
              show_default=True, help="json: one JSON line per input, in input order.")
@click.option("--output", type=click.Path(dir_okay=False),
              help="Write here instead of standard output (only when complete; -: standard "
                   "output).")
@click.option("--annotate", "annotate_path", type=click.Path(),
              help="Write the frame as a PNG with the identified stars labelled (with "
                   "several inputs: a folder, or NAME.png for NAME_<input>.png beside it).")
@click.option("--wcs", "wcs_path", type=click.Path(),
              help="Write the solved WCS as a FITS header (with several inputs: a folder, "
                   "or NAME.wcs for NAME_<input>.wcs beside it).")
@click.option("--corr", "corr_path", type=click.Path(dir_okay=False),
              help="Write matched stars (pixel, flux, catalog magnitude, residual) as CSV.")
@click.option("--overwrite", is_flag=True,
              help="Replace existing --output, --annotate, --wcs and --corr files (an input "
                   "never; docs/conventions.md).")
@click.option("-q", "--quiet", is_flag=True, help="No progress bar or notes on stderr.")
@click.option("-v", "--verbose", is_flag=True,
              help="One line per input and per file written on stderr.")
@click.option("--track", is_flag=True,
              help="The inputs, in order, are one sequence: the first is solved "
                   "lost-in-space, each later one by tracking from those before it (falling "
                   "back to lost-in-space); each record says its mode and lock.")
@click.option("--prior", callback=triple("RA,DEC,ROLL"),
              help="Prior attitude RA,DEC,ROLL in degrees: each input (with --track, the "
                   "first) is solved near it first.")
@click.option("--prior-sigma-deg", type=Number(SOLVER_BOUNDS["prior_sigma_deg"]),
              default=DEFAULT_PRIOR_SIGMA_DEG, show_default=True,
              help="1-sigma uncertainty of --prior, degrees.")
@hint_options
@click.option("--downsample", type=Number(DOWNSAMPLE), default=1, show_default=True,
              help="Find the centroids on the image binned N x N (large frames); they are "
                   "reported in full-resolution pixels.")
@click.option("--config", "config_path", type=click.Path(dir_okay=False),
              help="A TOML preset (configs/*.toml, or its name): its [camera] and [sky] "
                   "as defaults that the options override.")
def identify(inputs, **given) -> None:
    """Identify the stars of each INPUT (PNG, TIFF, FITS image or centroid CSV) and solve
    its attitude. Camera and sky come from the JSON sidecar beside the input when present
    (options override it). Exit 0 when every input is solved, 1 when one is not, 2 on bad
    usage or an unreadable input (the other inputs are still answered).
    Conventions (pixels, attitude, JSON record, exit codes): docs/conventions.md."""
    out = OutputChoice(**{f.name: given.pop(f.name) for f in fields(OutputChoice)})
    writer, output = _output_writer(inputs, given["camera_path"], out.overwrite, out.output)
    side = SideOutputs(writer, list(inputs), out.annotate_path, out.wcs_path, out.corr_path)
    solver = _solver(given)
    worst = _answer_all(inputs, solver, out, writer, output, side, prior_alone=(
        given["prior"] is not None and not (given["track"] or out.quiet)),
        fov_option=None if out.quiet else given["fov_deg"] is not None)
    say_written(side.written, out.quiet, out.verbose, output)
    sys.exit(worst)


@dataclass(frozen=True)
class OutputChoice:
    """Where and how `identify` answers: the records' format and file, the side files,
    and how much it says on stderr."""

    fmt: str
    output: str | None
    annotate_path: str | None
    wcs_path: str | None
    corr_path: str | None
    overwrite: bool
    quiet: bool
    verbose: bool


def _answer_all(inputs, solver, out: OutputChoice, writer, output, side, prior_alone: bool,
                fov_option: bool | None) -> int:
    """Solve every input in order and write its record; the worst exit code."""
    # the compiled core: when run
    from startrack.outputs import EXIT_CODES, error_record, frame_record

    note = verbose_notes(out.quiet, out.verbose)
    worst = 0
    pending: list[dict] = []  # error records held back until an input is answered
    try:
        with contextlib.ExitStack() as stack:
            fh = (stack.enter_context(writer.text(output, "--output")) if output
                  else guarded_stdout())
            emit = record_writer(fh, out.fmt, several=len(inputs) > 1)
            todo = inputs_with_progress(inputs, out.quiet, stack)
            if todo is not inputs and not output:
                emit = around_bar(emit)
            for name in todo:
                result = None
                try:
                    result = solver.run(Path(name))
                    side.add(result)
                except InputError as exc:  # a batch answers every input it can
                    if result is None:  # unread: in a sequence, a frame with no answer
                        solver.skip()
                    click.echo(f"error: {exc}", err=True)
                    pending.append(error_record(name, str(exc)))
                    worst = 2
                    continue
                record = frame_record(result)
                _report(note, name, record, prior_alone, fov_option)
                worst = max(worst, EXIT_CODES[record["status"]])
                for rec in [*pending, record]:
                    emit(rec)
                pending.clear()
            if len(pending) == len(inputs):
                raise NothingAnswered  # no input could be read: leave no output at all
            for rec in pending:
                emit(rec)
            side.finish()
    except NothingAnswered:
        pass
    return worst


def _output_writer(inputs, camera_path, overwrite: bool, output):
    """The writer of every output (never an input or its sidecar) and ``--output``, checked
    before any work; ``-`` is standard output (None), as in every Unix tool."""
    from startrack.io import with_sidecars

    writer = Writer([*with_sidecars(inputs), *([camera_path] if camera_path else [])],
                    overwrite)
    output = None if output == "-" else output
    if output:
        writer.check(output, "--output")
    return writer, output


def _options(camera_path, fov_deg, hint_values: dict, **given) -> Options:
    """The pipeline's options: the camera file and the hints decided, the other values as
    given (a ``--config`` preset is the builder's: :func:`startrack.api.build_solver`)."""
    from startrack.solver import Options  # scipy.spatial and the compiled core: when run

    if camera_path and fov_deg is not None:
        raise click.UsageError("give --camera FILE or --fov DEG, not both (the camera file "
                               "sets the field of view)")
    # the camera (and the compiled core under it) loads only when a command runs
    from startrack.camera import load_camera
    camera = load_camera(camera_path) if camera_path else None
    hints = hints_from(hint_values, fov_given=camera is not None or fov_deg is not None)
    return Options(camera=camera, fov_deg=fov_deg, hints=hints,
                   header_hints=not hint_values["no_header_hints"], **given)


def _report(note, name: str, record: dict, prior_alone: bool, fov_option: bool | None) -> None:
    """The -v line of an input; (a --prior without --track) one stderr line when it was
    solved lost-in-space instead; and (``fov_option`` not None: not -q) one when a
    nominal FOV found no match, saying what to try (``fov_option``: --fov gave it)."""
    note(summary_line(record))
    suggestion = None if fov_option is None else fov_suggestion(record, fov_option)
    if suggestion:
        click.echo(f"note: {name}: {suggestion}", err=True)
    if prior_alone and "fallback" in record:
        click.echo(f"note: {name}: not solved near --prior ({record['fallback']}); solved "
                   "lost-in-space", err=True)


def _solver(given: dict):
    """The solver of every input from the solving options (the one assembly the Python API
    uses too)."""
    # the compiled core and scipy.spatial load only when the command runs
    from startrack.api import SequenceChoice, SolverRequest, build_solver

    given = dict(given)
    sequence = SequenceChoice(given.pop("track"), given.pop("prior"),
                              given.pop("prior_sigma_deg"))
    config_path = given.pop("config_path")
    hint_values = {k: given.pop(k) for k in HINT_KEYS}
    given["time"] = given.pop("obs_time")
    options = _options(given.pop("camera_path"), given.pop("fov_deg"), hint_values, **given)
    return build_solver(SolverRequest(options, config_path, sequence))
