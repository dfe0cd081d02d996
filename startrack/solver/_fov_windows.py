"""The focal-length windows a nominal or unknown field of view is searched in, and their
order (:func:`passes`): the geometry of :mod:`startrack.solver._fov_search`."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from startrack.camera import Camera

WINDOW_STEP = 2.0 ** 0.25  # ratio of the focal lengths at a search window's two ends
MARGIN = 0.02  # searched beyond the tolerance, as a fraction


def windows(f_lo: float, f_hi: float, step: float = WINDOW_STEP) -> list[tuple[float, float]]:
    """[f_lo, f_hi] cut into geometric windows at most ``step`` wide (ratio)."""
    n = max(1, math.ceil(math.log(f_hi / f_lo) / math.log(step) - 1e-9))
    edges = f_lo * (f_hi / f_lo) ** (np.arange(n + 1) / n)
    edges[0], edges[-1] = f_lo, f_hi  # the ends exact: windows of a range's parts tile it
    return [(float(a), float(b)) for a, b in zip(edges[:-1], edges[1:], strict=True)]


def focal_range(camera: Camera, tolerance: float) -> tuple[float, float]:
    """The focal lengths of the FOVs within ``tolerance`` (a fraction) of ``camera``'s,
    widened by ``MARGIN``: a true FOV at the very edge must still be found."""
    fov = camera.fov_deg
    hi_fov = min(fov * (1.0 + tolerance) * (1.0 + MARGIN), 179.0)
    return (f_of_fov(camera.width, hi_fov),
            f_of_fov(camera.width, fov * (1.0 - tolerance) / (1.0 + MARGIN)))


def f_of_fov(width: int, fov_deg: float) -> float:
    return (width / 2.0) / math.tan(math.radians(fov_deg) / 2.0)


@dataclass(frozen=True)
class Pass:
    """One look at one focal-length window: its ends, how many pattern levels below the
    nearest, and whether only its first strong candidate is tried
    (:meth:`startrack.matchers._quad.QuadMatcher.strong`) or all of them, ranked."""

    f_lo: float
    f_hi: float
    deeper: int = 0
    strong_only: bool = False


@functools.lru_cache(maxsize=64)  # a camera's range repeats frame after frame
def passes(f_lo: float, f_hi: float, f_nominal: float | None = None) -> tuple[Pass, ...]:
    """[f_lo, f_hi]'s windows in search order: first each strong candidate (found without
    ranking) of windows twice as wide, where most frames end, having paid little for the
    wrong ones; then every window's candidates ranked, at its nearest pattern level, then
    one level deeper (fainter pattern stars: a sparse patch of sky holds too few of the
    nearest level's), so a frame an earlier pass solves costs no more. With a nominal
    focal length ``f_nominal`` the strong windows start at one centred on it and go
    outward, nearest first (a wide range, as ``--scale-low/--scale-high`` give, was
    searched from its widest field, two or three windows of strong lookups before the
    nominal's); without, from the widest field."""
    spans = windows(f_lo, f_hi)
    strong = (windows(f_lo, f_hi, WINDOW_STEP ** 2) if f_nominal is None
              else centred_windows(f_lo, f_hi, f_nominal, WINDOW_STEP ** 2))
    return tuple([Pass(lo, hi, 0, True) for lo, hi in strong]
                 + [Pass(lo, hi, deeper) for deeper in (0, 1) for lo, hi in spans])


def centred_windows(f_lo: float, f_hi: float, f_centre: float,
                    step: float) -> list[tuple[float, float]]:
    """[f_lo, f_hi] cut into windows at most ``step`` wide: the first centred on
    ``f_centre`` (held inside the range; a sliver left at an end, under a quarter of a
    step, joins it), then the rest of each side cut by :func:`windows`, nearest the
    centre first."""
    centre = min(max(f_centre, f_lo), f_hi)
    half, sliver = math.sqrt(step), step ** 0.25
    lo, hi = max(f_lo, centre / half), min(f_hi, centre * half)
    lo = f_lo if lo / f_lo < sliver else lo
    hi = f_hi if f_hi / hi < sliver else hi
    below = windows(f_lo, lo, step)[::-1] if lo > f_lo else []
    above = windows(hi, f_hi, step) if hi < f_hi else []

    def distance(span: tuple[float, float]) -> float:  # of its nearer end, in log f
        return min(abs(math.log(span[0] / centre)), abs(math.log(span[1] / centre)))

    return [(lo, hi)] + sorted(below + above, key=distance)


__all__ = ["MARGIN", "WINDOW_STEP", "Pass", "centred_windows", "f_of_fov", "focal_range",
           "passes", "windows"]
