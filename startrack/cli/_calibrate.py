"""`startrack calibrate`: fit a camera file (focal length, principal point, distortion)."""

from __future__ import annotations

import dataclasses
import json
import math
import sys
from pathlib import Path

import click

from startrack.cli import main
from startrack.cli._hint_options import hint_options, hints_from
from startrack.cli._identify import _size
from startrack.cli._shared_options import (
    SKY_HELP,
    SKY_NAME,
    Number,
    index_dir_option,
    notes,
    verbosity,
)
from startrack.defaults import DEFAULT_METHOD
from startrack.errors import InputError
from startrack.input_checks import DOWNSAMPLE, EPOCH_YEAR, FOV_DEG, MAG_LIMIT
from startrack.io import Writer


@main.command()
@click.argument("inputs", nargs=-1, required=True, type=click.Path(dir_okay=False))
@click.option("--fov", "fov_deg", type=Number(FOV_DEG),
              help="Nominal horizontal field of view in degrees (a datasheet "
                   "value: up to 10% off is searched).")
@click.option("--camera", "camera_path", type=click.Path(dir_okay=False),
              help="Nominal camera file instead of --fov (its distortion is the start).")
@click.option("--size", callback=_size, help="Image size WxH for centroid CSVs with --fov.")
@click.option("--output", required=True, type=click.Path(dir_okay=False),
              help="Camera file to write (JSON, keys in docs/conventions.md).")
@click.option("--overwrite", is_flag=True,
              help="Replace an existing --output file (an input never).")
@click.option("--terms", type=click.IntRange(0, 3), default=1, show_default=True,
              help="Radial distortion coefficients to fit: 0 none, 1 k1, 2 k1 k2, 3 k1-k3.")
@click.option("--fix-center", is_flag=True, help="Keep the principal point of the nominal "
              "camera instead of fitting it.")
@click.option("--sky", type=SKY_NAME,
              help=SKY_HELP + " Default: the --config preset's sky, else hipparcos.")
@index_dir_option
@click.option("--mag-limit", type=Number(MAG_LIMIT), help="Faintest catalog magnitude.")
@click.option("--epoch", type=Number(EPOCH_YEAR),
              help="Julian year to carry catalog positions to by proper motion.")
@click.option("--method", default=DEFAULT_METHOD, show_default=True, help="Matcher.")
@hint_options
@click.option("--config", "config_path", type=click.Path(dir_okay=False),
              help="A TOML preset (configs/*.toml, or its name): its [camera] is the nominal "
                   "camera unless --fov, --camera or a scale range is given, its [sky] the "
                   "sky unless --sky (--mag-limit, --epoch override it).")
@click.option("--downsample", type=Number(DOWNSAMPLE), default=1, show_default=True,
              help="Find the centroids on the images binned N x N.")
@verbosity
def calibrate(inputs, fov_deg, camera_path, size, output, overwrite, terms, fix_center, sky,
              mag_limit, epoch, method, config_path, downsample, quiet, verbose,
              **hint_values) -> None:
    """Solve every INPUT (images or centroid CSVs from one camera), fit its focal length,
    principal point and radial distortion by least squares over all matched stars (with
    outlier rejection), write the camera file and print the residual RMS before and after.
    Exit 1 when no input solves (nothing is written)."""
    from startrack.api import preset
    from startrack.io import with_sidecars
    from startrack.matchers import get_matcher
    from startrack.sky import sky_spec
    from startrack.solver import calibrate as run  # the compiled core: only when run

    hints = hints_from(hint_values, fov_given=fov_deg is not None or camera_path is not None)
    if fov_deg is not None and camera_path is not None:
        raise InputError("calibrate: give exactly one of --fov DEG and --camera FILE")
    preset_camera, preset_sky = preset(config_path, None, fov_deg, hints)
    preset_camera = None if camera_path is not None else preset_camera
    get_matcher(method)
    writer = Writer([*with_sidecars(inputs), *([camera_path] if camera_path else [])],
                    overwrite)
    writer.check(output, "--output")  # before any work
    note, detail = notes(quiet, verbose)
    from startrack.solver import read_input  # the compiled centroider: at run time
    frames = [read_input(Path(name), downsample=downsample) for name in inputs]
    if fov_deg is None and camera_path is None and preset_camera is None:
        fov_deg = hinted_fov(frames, hints, size, not hint_values["no_header_hints"])
    nominal = _nominal(frames, fov_deg, camera_path, size, preset_camera)
    catalog = _catalog(sky_spec(sky) if sky else (preset_sky or sky_spec("hipparcos")),
                       mag_limit, epoch, nominal, hints)
    result = run(frames, nominal, catalog, method=method, terms=terms,
                 fit_center=not fix_center)
    if result is None:
        cone = " and within --radius of --ra/--dec" if hints and hints.pointing else ""
        note(f"calibrate: none of the {len(frames)} input(s) solved within 10% of the "
             f"nominal field of view{cone}; nothing written")
        sys.exit(1)
    for name in result.unsolved:
        note(f"calibrate: {name}: not solved, left out")
    for name in result.solved:
        detail(f"calibrate: {name}: solved")
    cam = result.camera
    with writer.text(output, "--output") as fh:
        json.dump({**cam.to_dict(), "uncertainty": {
            p.name: {"sigma": p.sigma, "status": p.status, "fit": p.fit}
            for p in result.parameters}}, fh, indent=2)
        fh.write("\n")
    _print_result(result, nominal, len(frames))
    click.echo(f"wrote {output}")


def _catalog(spec, mag_limit, epoch, nominal, hints):
    """The catalog to match against: ``spec`` with the options applied, cut to the
    pointing hint's cone when there is one."""
    from startrack.sky import load_sky, resolve_sky

    given = {"mag_limit": mag_limit, "epoch": epoch}
    spec = dataclasses.replace(spec, **{k: v for k, v in given.items() if v is not None})
    catalog = load_sky(resolve_sky(spec, nominal), nominal)
    if hints is not None and hints.pointing is not None:
        from startrack.solver import cone_radius_deg, cut_to_cone

        catalog = cut_to_cone(catalog, hints.pointing,
                              cone_radius_deg(hints.pointing, nominal, 0.1, 0.0))
    return catalog


def _print_result(result, nominal, n_frames: int) -> None:
    """The fit's summary: inputs solved, residuals before and after, every parameter."""
    from startrack.solver import format_parameters

    cam = result.camera
    d = cam.distortion.to_dict() if cam.distortion else {"k1": 0.0, "k2": 0.0, "k3": 0.0}
    click.echo(f"calibrate: {len(result.solved)} of {n_frames} input(s) solved, "
               f"{result.n_stars} stars fitted ({result.n_rejected} rejected as outliers)")
    click.echo(f"residual RMS before: {result.rms_before_px:.3f} px (nominal camera, "
               "attitudes refitted)")
    click.echo(f"residual RMS after:  {result.rms_after_px:.3f} px")
    click.echo(f"fov_deg {cam.fov_deg:.4f} (nominal {nominal.fov_deg:.4f}), f {cam.f_px:.2f} px, "
               f"cx {cam.cx:.2f}, cy {cam.cy:.2f}, k1 {d['k1']:.5f}, k2 {d['k2']:.5f}, "
               f"k3 {d['k3']:.5f}")
    for line in format_parameters(result.parameters):
        click.echo(line)


def hinted_fov(frames, hints, size, header: bool) -> float:
    """The nominal FOV from a scale range (its middle), else the first FITS input's
    header; an error naming the options when there is neither."""
    from startrack.solver import fov_range_deg, header_hints

    dims = size or next((f.size for f in frames if f.size is not None), None)
    if hints is not None and hints.scale is not None:
        if dims is None:
            raise InputError("calibrate: centroid lists with a scale range need --size WxH")
        return fov_range_deg(hints.scale, dims[0])[0]
    for frame in frames if header else []:
        found = header_hints(frame.path, dims)
        if found is not None:
            return fov_range_deg(found.scale, dims[0])[0]
    raise InputError("calibrate: give exactly one of --fov DEG and --camera FILE (or a "
                     "scale range, or FITS inputs with a WCS)")


def _nominal(frames, fov_deg, camera_path, size, preset_camera=None):
    """The nominal camera: the file, the --config preset's, or --fov with the image (or
    --size) dimensions."""
    from startrack.camera import Camera

    sizes = {f.size for f in frames if f.size is not None}
    if len(sizes) > 1:
        raise InputError(f"calibrate: the images differ in size ({sorted(sizes)}); "
                         "calibrate one camera at a time")
    if camera_path is not None:
        # the camera (and the compiled core under it) loads only when a command runs
        from startrack.camera import load_camera
        camera = load_camera(camera_path)
    elif preset_camera is not None:
        camera = preset_camera
    else:
        dims = size or (next(iter(sizes)) if sizes else None)
        if dims is None:
            raise InputError("calibrate: centroid lists with --fov need --size WxH")
        camera = Camera.from_fov(dims[0], dims[1], fov_deg)
    if sizes and next(iter(sizes)) != (camera.width, camera.height):
        w, h = next(iter(sizes))
        raise InputError(f"calibrate: the images are {w} x {h} px but the camera is "
                         f"{camera.width} x {camera.height}")
    if not math.isfinite(camera.f_px):
        raise InputError("calibrate: the nominal camera has no finite focal length")
    return camera

__all__ = ["calibrate", "hinted_fov"]
