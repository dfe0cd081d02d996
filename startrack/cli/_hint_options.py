"""The hint options that ``identify`` and ``calibrate`` share (startrack.solver._hints)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import click

from startrack.cli._shared_options import Number
from startrack.defaults import SCALE_UNITS
from startrack.input_checks import DEC_DEG, PIXEL_SIZE_UM, RA_DEG, RADIUS_DEG, SCALE

if TYPE_CHECKING:
    from startrack.solver import Hints

HINT_KEYS = ("ra", "dec", "radius", "scale_low", "scale_high", "scale_units", "pixel_size",
             "no_header_hints")


def hint_options(command):
    """Add the hint options to a click command (they arrive as the :data:`HINT_KEYS`
    keywords; :func:`hints_from` turns them into :class:`~startrack.solver._hints.Hints`)."""
    options = [
        click.option("--ra", type=Number(RA_DEG), help="The boresight lies within --radius of RA "
                     "(deg) and --dec: only catalog stars around it are searched (no roll "
                     "needed)."),
        click.option("--dec", type=Number(DEC_DEG),
                     help="Dec (deg) of the pointing hint (with --ra, --radius)."),
        click.option("--radius", type=Number(RADIUS_DEG),
                     help="Radius (deg) of the pointing hint."),
        click.option("--scale-low", type=Number(SCALE), help="Smallest image scale (with "
                     "--scale-high and --scale-units), instead of --fov."),
        click.option("--scale-high", type=Number(SCALE), help="Largest image scale."),
        click.option("--scale-units", type=click.Choice(SCALE_UNITS), default="degwidth",
                     show_default=True, help="solve-field's units: image width in degrees, "
                     "arcsec per pixel, or the lens focal length in mm (needs "
                     "--pixel-size)."),
        click.option("--pixel-size", type=Number(PIXEL_SIZE_UM),
                     help="Pixel size in micrometres (for "
                     "--scale-units focalmm)."),
        click.option("--no-header-hints", is_flag=True, help="Ignore a FITS input's "
                     "header (its WCS pointing and scale, DATE-OBS, EXPTIME), used by "
                     "default."),
    ]
    for option in reversed(options):
        command = option(command)
    return command


def hints_from(values: dict, fov_given: bool) -> Hints | None:
    """The user's :class:`Hints` from the options' values; None when none was given."""
    from startrack.solver import user_hints  # scipy.spatial (startrack.sky): when run only

    return user_hints(values["ra"], values["dec"], values["radius"], values["scale_low"],
                      values["scale_high"], values["scale_units"], values["pixel_size"],
                      fov_given=fov_given)

__all__ = ["HINT_KEYS", "hint_options", "hints_from"]
