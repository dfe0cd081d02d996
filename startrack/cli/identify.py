"""`startrack identify`: images or centroid CSVs in, attitude and star identities out."""

from __future__ import annotations

import contextlib
import csv
import json
import math
import sys
from pathlib import Path

import click

from startrack.cache import atomic_text
from startrack.camera_file import load_camera
from startrack.centroids import DEFAULT_SIGMA_PX
from startrack.cli import main
from startrack.errors import InputError
from startrack.fov import BLIND_FOV_RANGE, DEFAULT_FOV_TOLERANCE
from startrack.matchers import available_methods
from startrack.output import CSV_HEADER, EXIT_CODES, csv_rows, error_record, format_table
from startrack.pipeline import DEFAULT_METHOD, Options, Pipeline
from startrack.sky import GAIA_BELOW_FOV_DEG, SKY_KINDS


def _size(ctx, param, value):
    if value is None:
        return None
    try:
        w, h = (int(p) for p in value.lower().split("x"))
    except ValueError:
        raise click.BadParameter(f"expected WxH in pixels, e.g. 1024x768, got {value!r}") \
            from None
    if w < 1 or h < 1:
        raise click.BadParameter(f"width and height must be positive, got {value!r}")
    return w, h


def _finite(ctx, param, value):
    if value is not None and not math.isfinite(value):
        raise click.BadParameter(f"must be a finite number, got {value}")
    return value


@main.command()
@click.argument("inputs", nargs=-1, required=True, type=click.Path(dir_okay=False))
@click.option("--camera", "camera_path", type=click.Path(dir_okay=False),
              help="Camera file (JSON or TOML, interfaces.md keys).")
@click.option("--fov", "fov_deg", type=click.FloatRange(0, 180, min_open=True, max_open=True),
              help="Horizontal field of view in degrees (image size from the image, or "
                   "--size for a CSV).")
@click.option("--fov-tolerance", type=click.FloatRange(0, 0.5), default=DEFAULT_FOV_TOLERANCE,
              show_default=True,
              help="The true FOV may be this fraction above or below --fov (or the camera "
                   "file's); it is fitted and reported as fov_deg. 0: exactly as given. "
                   "With no FOV at all (no --fov, camera file or sidecar) a blind search "
                   f"covers {BLIND_FOV_RANGE[0]:g} to {BLIND_FOV_RANGE[1]:g} deg.")
@click.option("--size", callback=_size, help="Image size WxH for a centroid CSV with --fov.")
@click.option("--sky", type=click.Choice(SKY_KINDS),
              help="Catalog: the frame sidecar's sky, else gaia below "
                   f"{GAIA_BELOW_FOV_DEG:g} deg or with no FOV, hipparcos otherwise.")
@click.option("--mag-limit", type=float, callback=_finite,
              help="Faintest catalog magnitude. Default for hipparcos: the faintest half "
                   "magnitude with <= 80 catalog stars in an average frame (20 deg -> 6.5, "
                   "11.4 deg -> 7.5).")
@click.option("--epoch", type=float, callback=_finite,
              help="Julian year to carry Hipparcos positions to by proper motion "
                   "(default: the catalog epoch, J1991.25).")
@click.option("--method", default=DEFAULT_METHOD, show_default=True,
              help=f"Matcher, one of: {', '.join(available_methods())} (docs/results.md "
                   "compares them).")
@click.option("--max-stars", type=click.IntRange(min=3),
              help="Brightest stars the matcher may use to form patterns.")
@click.option("--sigma-px", type=click.FloatRange(0, min_open=True), callback=_finite,
              default=DEFAULT_SIGMA_PX, show_default=True,
              help="1-sigma centroid error in pixels; sets match tolerances.")
@click.option("--format", "fmt", type=click.Choice(["table", "json", "csv"]), default="table",
              show_default=True, help="json: one JSON line per input, in input order.")
@click.option("--output", type=click.Path(dir_okay=False),
              help="Write here instead of standard output (only when complete).")
def identify(inputs, camera_path, fov_deg, fov_tolerance, size, sky, mag_limit, epoch, method,
             max_stars, sigma_px, fmt, output) -> None:
    """Identify the stars of each INPUT (PNG, TIFF, FITS image or centroid CSV) and solve
    its attitude. Camera and sky come from the JSON sidecar beside the input when present
    (options override it). Exit 0 when every input is solved, 1 when one is not, 2 on bad
    usage or an unreadable input (the other inputs are still answered).
    Conventions (pixels, attitude, JSON record, exit codes): docs/conventions.md."""
    camera = load_camera(camera_path) if camera_path else None
    options = Options(method=method, camera=camera, fov_deg=fov_deg, size=size, sky=sky,
                      mag_limit=mag_limit, epoch=epoch, max_stars=max_stars, sigma_px=sigma_px,
                      fov_tolerance=fov_tolerance)
    pipeline = Pipeline(options)
    worst = 0
    pending: list[dict] = []  # error records held back until an input is answered
    try:
        with contextlib.ExitStack() as stack:
            fh = stack.enter_context(atomic_text(output)) if output else sys.stdout
            emit = _writer(fh, fmt, several=len(inputs) > 1)
            for name in inputs:
                try:
                    record = pipeline.run(Path(name)).record()
                except InputError as exc:  # a batch answers every input it can
                    click.echo(f"error: {exc}", err=True)
                    pending.append(error_record(name, str(exc)))
                    worst = 2
                    continue
                worst = max(worst, EXIT_CODES[record["status"]])
                for rec in [*pending, record]:
                    emit(rec)
                pending.clear()
            if len(pending) == len(inputs):
                raise _NothingAnswered  # no input could be read: leave no output at all
            for rec in pending:
                emit(rec)
    except _NothingAnswered:
        pass
    sys.exit(worst)


class _NothingAnswered(Exception):
    """Every input was bad: the atomic output is discarded rather than written."""


def _writer(fh, fmt: str, several: bool):
    """A function writing one record to ``fh`` in ``fmt`` (the CSV header first)."""
    writer = csv.writer(fh) if fmt == "csv" else None
    if writer is not None:
        writer.writerow(CSV_HEADER)

    def emit(record: dict) -> None:
        if fmt == "json":
            fh.write(json.dumps(record) + "\n")
        elif writer is not None:
            writer.writerows(csv_rows(record))
        else:
            fh.write(format_table(record) + ("\n" if several else ""))
        fh.flush()

    return emit
