"""The condition grid of a comparison: noise, false-star, dropout, camera-error and
sensor/space-effect levels.

A condition fixes every variable. The default "one-at-a-time" design sweeps one variable
while the others stay at the base condition (the first value of each list), which keeps a
run small; ``grid="full"`` runs the whole Cartesian product instead.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import asdict, dataclass

from startrack.errors import InputError
from startrack.simulate import REFERENCE_BV, REFERENCE_C

#: where a frame's centroids come from: the scene's, or extracted from its rendered image
SOURCES = ("centroids", "images")

# The swept variables, in column order; each is a field of Condition.
VARIABLES = ("noise_px", "false_stars", "missing", "mag_noise", "fov_error", "distortion_k1",
             "modelled_k1", "cosmic_rays", "stray_light", "temperature_c", "colour_index")
#: the effect variables: they act on rendered pixels (``--from images``) only
EFFECT_VARIABLES = ("cosmic_rays", "stray_light", "temperature_c", "colour_index")
#: variables a caller may leave out of ``levels`` (the camera is then exact, the effects off)
OPTIONAL = {"fov_error": (0.0,), "distortion_k1": (0.0,), "modelled_k1": (0.0,),
            "cosmic_rays": (0.0,), "stray_light": (0.0,), "temperature_c": (REFERENCE_C,),
            "colour_index": (REFERENCE_BV,)}
GRIDS = ("oat", "full")


@dataclass(frozen=True)
class Condition:
    """One setting of every perturbation: centroid noise (px, 1 sigma per axis), false
    stars per frame, star dropout probability, magnitude noise (mag, 1 sigma), and the
    camera: ``fov_error`` is the fractional error of the FOV the matcher is told (its
    camera has ``fov * (1 + fov_error)``); the frames are seen through a lens with radial
    distortion ``k1 = distortion_k1 + modelled_k1``, of which the matcher's camera carries
    only ``modelled_k1`` (so ``distortion_k1`` is the part it does not know about).
    The effects (rendered frames only): cosmic-ray hits per cm^2 per s, stray light at
    the field's centre in e-/px/s, and the detector temperature in C (the sensor's dark
    current holds at 20 C and doubles every [detector] ``dark_doubling_c``), and the B-V
    colour every star of the frame is given, seen through the config's [band] (at the
    Sun-like ``REFERENCE_BV``, the base, colour changes nothing)."""

    noise_px: float = 0.0
    false_stars: int = 0
    missing: float = 0.0
    mag_noise: float = 0.0
    fov_error: float = 0.0
    distortion_k1: float = 0.0
    modelled_k1: float = 0.0
    cosmic_rays: float = 0.0
    stray_light: float = 0.0
    temperature_c: float = REFERENCE_C
    colour_index: float = REFERENCE_BV

    def to_dict(self) -> dict:
        return asdict(self)


def is_default(variable: str, value: float) -> bool:
    """True when ``value`` is the variable's off (default) level."""
    return value == Condition.__dataclass_fields__[variable].default


#: the variables past the first four that tables show when a run sets them, with their
#: short column names
EXTRA_COLUMNS = {"fov_error": "fov_err", "distortion_k1": "k1", "modelled_k1": "k1_mod",
                 "cosmic_rays": "cosmic", "stray_light": "stray", "temperature_c": "temp_c",
                 "colour_index": "b_v"}


def set_extras(table) -> list[tuple[str, str]]:
    """(variable, short name) of the extra variables that ``table`` (a summary with a
    column per variable) holds at a level other than their default."""
    return [(var, short) for var, short in EXTRA_COLUMNS.items()
            if var in table and not all(is_default(var, v) for v in table[var])]


def parse_values(text: str, option: str, *, integer: bool = False, low: float = 0.0,
                 high: float | None = None) -> tuple:
    """A comma-separated list of numbers such as ``0,0.5,1``; errors name the option."""
    parts = [p.strip() for p in str(text).split(",")]
    if not parts or any(p == "" for p in parts):
        raise InputError(f"{option}: expected a comma-separated list of numbers, got {text!r}")
    values = []
    for part in parts:
        try:
            value = int(part) if integer else float(part)
        except ValueError:
            kind = "integers" if integer else "numbers"
            raise InputError(f"{option}: expected a comma-separated list of {kind}, "
                             f"got {text!r}") from None
        if not math.isfinite(value) or value < low or (high is not None and value > high):
            bound = f"[{low}, {high}]" if high is not None else f">= {low}"
            raise InputError(f"{option}: every value must be {bound}, got {part!r}")
        values.append(value)
    if len(set(values)) != len(values):
        raise InputError(f"{option}: repeated value in {text!r}")
    return tuple(values)


def build_conditions(levels: dict[str, tuple], grid: str = "oat") -> list[Condition]:
    """The conditions to run, in a canonical order.

    ``levels`` maps each variable of :data:`VARIABLES` to its values; the first value is
    the base. "oat": the base condition, then each variable's other values with the rest
    at base. "full": every combination (the first variable varies slowest).
    """
    if grid not in GRIDS:
        raise InputError(f"--grid must be one of {', '.join(GRIDS)}, got {grid!r}")
    levels = {**OPTIONAL, **{k: v for k, v in levels.items() if v}}
    missing = [v for v in VARIABLES if not levels.get(v)]
    if missing:
        raise InputError(f"no values given for {', '.join(missing)}")
    if grid == "full":
        combos = itertools.product(*(levels[v] for v in VARIABLES))
        return [Condition(*c) for c in combos]
    base = {v: levels[v][0] for v in VARIABLES}
    conditions = [Condition(**base)]
    for var in VARIABLES:
        for value in levels[var][1:]:
            conditions.append(Condition(**{**base, var: value}))
    return conditions


def base_condition(conditions: list[Condition]) -> Condition:
    """The base condition (the first of the canonical order)."""
    return conditions[0]


def sweep(conditions: list[Condition], variable: str) -> list[int]:
    """Indices of the conditions that vary ``variable`` with every other variable at base,
    sorted by that variable's value (a one-variable slice through the grid)."""
    base = base_condition(conditions)
    others = [v for v in VARIABLES if v != variable]
    picked = [k for k, c in enumerate(conditions)
              if all(getattr(c, v) == getattr(base, v) for v in others)]
    return sorted(picked, key=lambda k: getattr(conditions[k], variable))

__all__ = [
    "Condition", "EFFECT_VARIABLES", "EXTRA_COLUMNS", "GRIDS", "OPTIONAL", "SOURCES", "VARIABLES",
    "base_condition", "build_conditions", "is_default", "parse_values", "set_extras", "sweep",
]
