"""The condition grid of a comparison: noise, false-star, dropout and camera-error levels.

A condition fixes every variable. The default "one-at-a-time" design sweeps one variable
while the others stay at the base condition (the first value of each list), which keeps a
run small; ``grid="full"`` runs the whole Cartesian product instead.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import asdict, dataclass

from startrack.errors import InputError

#: where a frame's centroids come from: the scene's, or extracted from its rendered image
SOURCES = ("centroids", "images")

# The swept variables, in column order; each is a field of Condition.
VARIABLES = ("noise_px", "false_stars", "missing", "mag_noise", "fov_error", "distortion_k1",
             "modelled_k1")
#: variables a caller may leave out of ``levels`` (the camera is then exact)
OPTIONAL = {"fov_error": (0.0,), "distortion_k1": (0.0,), "modelled_k1": (0.0,)}
GRIDS = ("oat", "full")


@dataclass(frozen=True)
class Condition:
    """One setting of every perturbation: centroid noise (px, 1 sigma per axis), false
    stars per frame, star dropout probability, magnitude noise (mag, 1 sigma), and the
    camera: ``fov_error`` is the fractional error of the FOV the matcher is told (its
    camera has ``fov * (1 + fov_error)``); the frames are seen through a lens with radial
    distortion ``k1 = distortion_k1 + modelled_k1``, of which the matcher's camera carries
    only ``modelled_k1`` (so ``distortion_k1`` is the part it does not know about)."""

    noise_px: float = 0.0
    false_stars: int = 0
    missing: float = 0.0
    mag_noise: float = 0.0
    fov_error: float = 0.0
    distortion_k1: float = 0.0
    modelled_k1: float = 0.0

    def to_dict(self) -> dict:
        return asdict(self)


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
    "Condition", "GRIDS", "OPTIONAL", "SOURCES", "VARIABLES", "base_condition",
    "build_conditions", "parse_values", "sweep",
]
