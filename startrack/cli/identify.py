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
from startrack.cli import main
from startrack.matchers import available_methods
from startrack.output import CSV_HEADER, csv_rows, format_table, solution_record
from startrack.pipeline import DEFAULT_METHOD, DEFAULT_SIGMA_PX, Options, Pipeline
from startrack.sky import SKY_KINDS


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
@click.option("--size", callback=_size, help="Image size WxH for a centroid CSV with --fov.")
@click.option("--sky", type=click.Choice(SKY_KINDS),
              help="Catalog: the frame sidecar's sky, else hipparcos.")
@click.option("--mag-limit", type=float, callback=_finite,
              help="Faintest catalog magnitude. Default for hipparcos: the faintest half "
                   "magnitude with <= 80 catalog stars in an average frame (20 deg -> 6.5, "
                   "11.4 deg -> 7.5).")
@click.option("--epoch", type=float, callback=_finite,
              help="Julian year to carry Hipparcos positions to by proper motion "
                   "(default: the catalog epoch, J1991.25).")
@click.option("--method", default=DEFAULT_METHOD, show_default=True,
              help=f"Matcher, one of: {', '.join(available_methods())}. The default, "
                   "pyramid, was the most reliable and the fastest measured (docs/results.md): "
                   "every method solved 100% of the standard Hipparcos benchmark with no wrong "
                   "attitude, but with 1 px noise, 10 false stars and 30% missing pyramid "
                   "solved 99% (triangle 83%, radial 46%, angle 22%), at a median of 11 ms.")
@click.option("--max-stars", type=click.IntRange(min=3),
              help="Brightest stars the matcher may use to form patterns.")
@click.option("--sigma-px", type=click.FloatRange(0, min_open=True), callback=_finite,
              default=DEFAULT_SIGMA_PX, show_default=True,
              help="1-sigma centroid error in pixels; sets match tolerances.")
@click.option("--format", "fmt", type=click.Choice(["table", "json", "csv"]), default="table",
              show_default=True, help="json: one JSON line per input, in input order.")
@click.option("--output", type=click.Path(dir_okay=False),
              help="Write here instead of standard output (only when complete).")
def identify(inputs, camera_path, fov_deg, size, sky, mag_limit, epoch, method, max_stars,
             sigma_px, fmt, output) -> None:
    """Identify the stars of each INPUT (PNG, TIFF, FITS image or centroid CSV) and solve
    its attitude. Camera and sky come from the JSON sidecar beside the input when present
    (options override it). Exit 0 when every input is solved, 1 when one is not, 2 on bad
    usage or input."""
    camera = load_camera(camera_path) if camera_path else None
    options = Options(method=method, camera=camera, fov_deg=fov_deg, size=size, sky=sky,
                      mag_limit=mag_limit, epoch=epoch, max_stars=max_stars, sigma_px=sigma_px)
    pipeline = Pipeline(options)
    all_solved = True
    with contextlib.ExitStack() as stack:
        fh = stack.enter_context(atomic_text(output)) if output else sys.stdout
        writer = csv.writer(fh) if fmt == "csv" else None
        if writer is not None:
            writer.writerow(CSV_HEADER)
        for name in inputs:
            result, ident = pipeline.run(Path(name))
            extra = {"sigma_px": ident.sigma_px,
                     "match_radius_px": ident.verify_config.radius_px(result.obs),
                     "sky": ident.catalog.source, "camera": ident.camera.to_dict()}
            record = solution_record(result.solution, result.obs, ident.catalog,
                                     result.timing, input_name=name, extra=extra)
            all_solved &= result.solution.solved
            if fmt == "json":
                fh.write(json.dumps(record) + "\n")
            elif writer is not None:
                writer.writerows(csv_rows(record))
            else:
                fh.write(format_table(record) + ("\n" if len(inputs) > 1 else ""))
            fh.flush()
    sys.exit(0 if all_solved else 1)
