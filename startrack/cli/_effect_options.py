"""The effect options of `startrack simulate` (one level each) and `startrack compare`
(a comma-separated list of levels, each a condition): cosmic rays, stray light and the
detector's temperature; compare also takes the stars' colour (``--colour-index``). Their
ranges are the effect tables' (startrack.simulate)."""

from __future__ import annotations

import dataclasses

import click

from startrack.cli._shared_options import Number
from startrack.simulate import LEO_FLUX, SAA_FLUX, Detector, Environment


def _bounds(cls, name: str):
    return next(f for f in dataclasses.fields(cls) if f.name == name).metadata["bounds"]


#: (option, parameter, effect table, field, help)
EFFECT_OPTIONS = (
    ("--cosmic-rays", "cosmic_rays", Environment, "cosmic_rays",
     f"Cosmic-ray hits per cm^2 per s (quiet low orbit ~{LEO_FLUX:g}, South Atlantic "
     f"Anomaly ~{SAA_FLUX:g})"),
    ("--stray-light", "stray_light", Environment, "stray_light",
     "Stray light at the field's centre, e-/px/s (a gradient across the field)"),
    ("--temperature", "temperature_c", Detector, "temperature_c",
     "Detector temperature, C (dark current doubles every [detector] dark_doubling_c)"),
)


def effect_options(command):
    """One level of each effect (simulate): overrides the config's tables."""
    for option, param, cls, name, text in reversed(EFFECT_OPTIONS):
        command = click.option(option, param, type=Number(_bounds(cls, name)),
                               help=f"{text} [default: the config's, else off].")(command)
    return command


def effect_levels_options(command):
    """A list of levels of each effect (compare): each level a condition."""
    for option, param, _cls, _name, text in reversed(EFFECT_OPTIONS):
        command = click.option(option, param, help=f"{text}; levels, first = base; "
                               "needs --from images [default: the config's, else off].")(command)
    return command


#: the B-V range of the band model's colour table (startrack.simulate's Band)
COLOUR_INDEX_RANGE = (-0.4, 2.5)


def colour_levels_option(command):
    """Compare's star-colour axis: each level a B-V given to every star of the frames."""
    low, high = COLOUR_INDEX_RANGE
    return click.option(
        "--colour-index", "colour_index",
        help=f"B-V of every star in the frames ({low:g} to {high:g}: blue to red), seen "
             "through the config's [band] filter and QE curves; levels, first = base; needs "
             "--from images and a [band] [default: none, i.e. Sun-like stars].")(command)


def effect_bounds(param: str):
    """The documented range of an effect option's values."""
    cls, name = next((c, n) for _o, p, c, n, _t in EFFECT_OPTIONS if p == param)
    return _bounds(cls, name)

__all__ = ["COLOUR_INDEX_RANGE", "EFFECT_OPTIONS", "colour_levels_option", "effect_bounds",
           "effect_levels_options", "effect_options"]
