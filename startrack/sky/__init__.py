"""Skies: which stars exist, where, and how bright (the first stage of the pipeline)."""

from __future__ import annotations

import dataclasses
import functools
import math
import os
from pathlib import Path

import numpy as np

from startrack._lazy import lazy_exports
from startrack.camera import Camera
from startrack.defaults import max_pairs
from startrack.errors import InputError
from startrack.io import FILE_KIND, SKY_KINDS, SkySpec
from startrack.sky._catalog import (
    Catalog,
    cut_magnitude,
    merge_close_stars,
    radec_to_vectors,
    vectors_to_radec,
)
from startrack.sky._default import (
    GAIA_BELOW_FOV_DEG,
    GAIA_MAG_MAX,
    TYCHO2_MAG_MAX,
    deeper_sky_note,
    default_sky_kind,
)
from startrack.sky._gaia import gaia_arrays, load_gaia
from startrack.sky._hipparcos import hipparcos_arrays, load_hipparcos
from startrack.sky._random_sky import random_sky
from startrack.sky._tycho2 import load_tycho2, tycho2_arrays
from startrack.sky._user_catalog import is_catalog_path, load_user_catalog


def with_sky(spec: SkySpec, name: str) -> SkySpec:
    """``spec`` with its kind (and file) replaced by ``--sky NAME``'s."""
    given = sky_spec(name)
    return dataclasses.replace(spec, kind=given.kind, path=given.path)


#: Stars closer than this many pixels are one spot to the sensor and are merged.
UNRESOLVED_PIXELS = 2.0


def merge_separation_deg(spec: SkySpec, camera: Camera | None) -> float:
    """The separation below which ``spec``'s stars are merged for ``camera``."""
    if spec.min_separation_deg is not None:
        return float(spec.min_separation_deg)
    if camera is None:
        return 0.0
    return math.degrees(UNRESOLVED_PIXELS / camera.f_px)


# Magnitude-limit rule for Hipparcos: the faintest half-magnitude step at which an
# average frame holds at most this many catalog stars (20 deg -> 6.5, 11.4 deg -> 7.5).
# More stars than this only slow the pattern search without making it more certain.
TARGET_STARS_PER_FRAME = 80.0


def default_mag_limit(camera: Camera, mags: np.ndarray, target: float = TARGET_STARS_PER_FRAME,
                      lo: float = 4.0, hi: float = 8.0) -> float:
    """Faintest limit in [lo, hi], in 0.5 mag steps, with <= ``target`` stars per frame."""
    frame_fraction = camera.width * camera.height / camera.f_px**2 / (4.0 * math.pi)
    mags = np.sort(np.asarray(mags, dtype=np.float64))
    limits = np.arange(lo, hi + 0.25, 0.5)
    counts = np.searchsorted(mags, limits, side="right") * frame_fraction
    fitting = limits[counts <= target]
    return float(fitting.max()) if len(fitting) else float(lo)


def sky_spec(name: str | os.PathLike) -> SkySpec:
    """The spec of ``--sky NAME``: a kind, or a catalog file (.csv, .fits, .parquet)."""
    name = os.fspath(name)
    if name in SKY_KINDS:
        return SkySpec(kind=name)
    if is_catalog_path(name):
        return SkySpec(kind=FILE_KIND, path=str(Path(name).resolve()))
    raise InputError(f"sky: {name!r} is neither one of {', '.join(SKY_KINDS)} nor a "
                     "catalog file (.csv, .fits, .parquet)")


def resolve_sky(spec: SkySpec, camera: Camera | None) -> SkySpec:
    """``spec`` with its defaults made explicit for ``camera``: the one home of the
    default magnitude rule (simulate, identify and compare all apply it). With no camera
    (an unknown field of view) a Gaia sky keeps every star; the blind search cuts it per
    field of view (:mod:`startrack.solver._fov_search`)."""
    if spec.mag_limit is not None or camera is None or spec.kind not in _MAG_SOURCES:
        return spec
    return dataclasses.replace(spec, mag_limit=_default_limit(spec.kind, camera))


def _hipparcos_mags() -> np.ndarray:
    return hipparcos_arrays()["mag"]


def _gaia_mags() -> np.ndarray:
    return gaia_arrays()["mag"]


def _tycho2_mags() -> np.ndarray:
    return tycho2_arrays()["mag"]


#: the catalogs whose default magnitude limit depends on the camera: their magnitudes and
#: the faintest limit the rule may choose
_MAG_SOURCES = {"hipparcos": (_hipparcos_mags, 8.0), "gaia": (_gaia_mags, GAIA_MAG_MAX),
                "tycho2": (_tycho2_mags, TYCHO2_MAG_MAX)}


@functools.lru_cache(maxsize=64)
def _default_limit(kind: str, camera: Camera) -> float:
    """The default magnitude limit of ``kind`` for ``camera``, computed once per process:
    it reads the whole catalog's magnitudes, which costs more than solving a frame."""
    mags, hi = _MAG_SOURCES[kind]
    return default_mag_limit(camera, mags(), hi=hi)


MAX_RANDOM_STARS = 5_000_000


def estimated_pairs(n_stars: int, max_angle_rad: float) -> float:
    """Expected catalog pairs closer than ``max_angle_rad`` for stars spread over the sky:
    each of n(n-1)/2 pairs is that close with probability (1 - cos a) / 2."""
    return n_stars * (n_stars - 1) / 2.0 * (1.0 - math.cos(max_angle_rad)) / 2.0


def check_pair_budget(catalog: Catalog, camera: Camera) -> None:
    """Refuse a catalog whose pair table for ``camera`` would exceed the budget."""
    angle = math.radians(camera.diagonal_fov_deg)
    pairs = estimated_pairs(len(catalog), angle)
    budget = max_pairs()
    if pairs > budget:
        mag = float(np.max(catalog.mag)) if len(catalog) else float("nan")
        raise InputError(
            f"sky: {len(catalog)} stars (to magnitude {mag:.1f}) make ~{pairs / 1e6:.0f} "
            f"million pairs across a {math.degrees(angle):.1f} deg frame, above the budget "
            f"of {budget / 1e6:.0f} million (STARTRACK_MAX_PAIRS); lower --mag-limit")


def _check_spec(spec: SkySpec) -> None:
    if spec.kind == "random":
        if spec.mag_limit is not None and not spec.mag_limit > 0.0:
            raise InputError(f"sky: a random sky's magnitudes start at 0, so --mag-limit must "
                             f"be > 0, got {spec.mag_limit}")
        if spec.n_stars > MAX_RANDOM_STARS:
            raise InputError(f"sky: n_stars {spec.n_stars} is above the limit of "
                             f"{MAX_RANDOM_STARS}")


def load_sky(spec: SkySpec | str | os.PathLike, camera: Camera | None = None) -> Catalog:
    """The catalog that ``spec`` describes, magnitude-cut and with close stars merged.

    Pass the camera the sky is seen through so that stars it cannot split are merged
    (:func:`merge_separation_deg`), as every command does. A sky named with a camera
    takes ``--sky NAME``'s defaults (:func:`resolve_sky`: the default magnitude limit).

    Parameters
    ----------
    spec : SkySpec, str or os.PathLike
        A :class:`SkySpec`, or ``--sky``'s name: ``"random"``, ``"hipparcos"``,
        ``"gaia"``, ``"tycho2"`` or a catalog file (.csv, .fits, .parquet).
    camera : Camera, optional
        The camera the sky is seen through (its pixel sets the merge separation).

    Returns
    -------
    Catalog
        ids, ra_deg, dec_deg, mag and unit vectors, brightest first.

    Raises
    ------
    startrack.errors.InputError
        An unknown kind, a missing catalog package or file, a bad value in the spec, or a
        magnitude limit that leaves no star.

    Examples
    --------
    >>> from startrack.camera import Camera
    >>> from startrack.sky import SkySpec, load_sky
    >>> sky = load_sky(SkySpec(kind="random", n_stars=500, seed=3))
    >>> len(sky), sky.vectors.shape, bool((sky.mag[:-1] <= sky.mag[1:]).all())
    (500, (500, 3), True)
    >>> len(load_sky("random", Camera.from_fov(1024, 1024, 20.0)))  # two stars merged
    1999
    >>> float(load_sky("hipparcos", Camera.from_fov(1024, 1024, 20.0)).mag.max()) <= 6.5
    True
    """
    if not isinstance(spec, SkySpec):
        spec = resolve_sky(sky_spec(spec), camera)
    _check_spec(spec)
    if spec.kind == "random":
        mag_max = 6.5 if spec.mag_limit is None else spec.mag_limit
        catalog = random_sky(n_stars=spec.n_stars, seed=spec.seed, mag_max=mag_max)
    elif spec.kind == "hipparcos":
        catalog = cut_magnitude(load_hipparcos(epoch=spec.epoch), spec.mag_limit)
    elif spec.kind == "gaia":
        catalog = cut_magnitude(load_gaia(epoch=spec.epoch), spec.mag_limit)
    elif spec.kind == "tycho2":
        catalog = cut_magnitude(load_tycho2(), spec.mag_limit)
    elif spec.kind == FILE_KIND and spec.path:
        catalog = cut_magnitude(load_user_catalog(spec.path, spec.epoch), spec.mag_limit)
    else:
        raise InputError(f"sky: kind must be one of {SKY_KINDS}, got {spec.kind!r}")
    if len(catalog) == 0:
        raise InputError(f"sky: no {spec.kind} star is brighter than magnitude "
                         f"{spec.mag_limit}; raise --mag-limit")
    catalog = merge_close_stars(catalog, merge_separation_deg(spec, camera))
    object.__setattr__(catalog, "source", spec.to_dict())
    return catalog


__all__ = [
    "BadId", "Catalog", "CATALOG_EPOCH", "catalog_file", "check_pair_budget", "cut_magnitude",
    "deeper_sky_note", "default_mag_limit", "default_sky_kind", "estimated_pairs", "exact_ids",
    "FILE_KIND", "fixed_width_column", "GAIA_BELOW_FOV_DEG", "gaia_bp_rp", "gaia_min_fov",
    "HIP2_COLUMNS", "index_files", "load_sky", "merge_close_stars", "merge_separation_deg",
    "parse_hip2",
    "propagate", "radec_to_vectors", "random_sky", "resolve_sky", "search_sky_kind",
    "set_index_dir", "sky_spec", "SkySpec", "UNRESOLVED_PIXELS", "vectors_to_radec",
    "with_sky",
]

# Other stages' entry points, each imported on first use.
__getattr__, __dir__ = lazy_exports(__name__, {
    "BadId": "_catalog",
    "CATALOG_EPOCH": "_hipparcos",
    "catalog_file": "_hipparcos",
    "exact_ids": "_catalog",
    "fixed_width_column": "_hipparcos",
    "gaia_bp_rp": "_gaia",
    "gaia_min_fov": "_default",
    "HIP2_COLUMNS": "_hipparcos",
    "index_files": "_tycho2",
    "parse_hip2": "_hipparcos",
    "propagate": "_hipparcos",
    "search_sky_kind": "_default",
    "set_index_dir": "_tycho2",
})
