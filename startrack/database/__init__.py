"""Star databases: the catalog's patterns, precomputed for one sky and field of view.

A :class:`StarDatabase` holds the catalog and builds each pattern table (pairs,
triangles, radial features) the first time a matcher asks for it, loading it from the
on-disk cache when the same sky, field of view and parameters were built before.
"""

from __future__ import annotations

import math
import time
from functools import cached_property

import numpy as np

from startrack._lazy import lazy_exports
from startrack.camera import Camera
from startrack.database import _triangles as tri
from startrack.database._cone import ConeIndex, CutCones, cone_index_of, held_cone_index
from startrack.database._kvector import KVector
from startrack.database._pairs import (
    PairTable,
    build_pair_arrays,
    pair_index_arrays,
    pair_table_from_arrays,
    select_pair_arrays,
)
from startrack.database._radial import build_radial_arrays, radial_table_from_arrays
from startrack.database._triangles import brighter_neighbours
from startrack.io import cached_arrays
from startrack.sky import Catalog


class StarDatabase:
    """Pattern tables for ``catalog`` as seen through ``camera``.

    ``max_angle_rad`` is the largest angle two stars of one frame can make (the image
    diagonal); pairs and triangles are kept only up to it.
    """

    def __init__(self, catalog: Catalog, camera: Camera) -> None:
        self.catalog = catalog
        self.camera = camera
        self.max_angle_rad = math.radians(camera.diagonal_fov_deg) * 1.001
        self.build_seconds: dict[str, float] = {}

    @property
    def vectors(self) -> np.ndarray:
        return self.catalog.vectors

    def _key(self, **extra) -> dict:
        return {"catalog": self.catalog.fingerprint(), "max_angle": round(self.max_angle_rad, 9),
                **extra}

    def _cached(self, kind: str, params: dict, build) -> dict[str, np.ndarray]:
        t0 = time.perf_counter()
        arrays = cached_arrays(kind, self._key(**params), build)
        self.build_seconds[kind] = time.perf_counter() - t0
        return arrays

    @cached_property
    def pairs(self) -> PairTable:
        """Every catalog pair closer than the image diagonal, sorted by angle."""
        return self._pair_table("pairs", {},
                                lambda: build_pair_arrays(self.vectors, self.max_angle_rad))

    def _pair_table(self, kind: str, params: dict, build) -> PairTable:
        """The cached pair table ``kind``, with its k-vector and neighbour lists from a
        cache entry of their own (built once from it): a process maps them instead of
        spending a third of a second building them before its first search."""
        arrays = self._cached(kind, params, build)
        n = len(self.vectors)
        index = cached_arrays(f"{kind}_index", self._key(**params, n_catalog=n),
                              lambda: pair_index_arrays(arrays, n))
        return pair_table_from_arrays(arrays, index)

    def pattern_pairs(self, max_per_region: int | None,
                      region_radius_deg: float | None = None) -> PairTable:
        """The pairs among pattern stars only: stars with fewer than ``max_per_region``
        brighter stars within ``region_radius_deg`` (default half the FOV), the thinning
        of :func:`startrack.database._triangles.brighter_neighbours`. None: every pair."""
        if max_per_region is None:
            return self.pairs
        radius = math.radians(region_radius_deg or self.camera.fov_deg / 2.0)
        key = (int(max_per_region), round(radius, 9))
        tables = self.__dict__.setdefault("_pattern_pairs", {})
        if key not in tables:
            def build() -> dict[str, np.ndarray]:
                keep = brighter_neighbours(self.vectors, radius) < key[0]
                p = self.pairs
                return select_pair_arrays({"i": p.i, "j": p.j, "angle": p.angle}, keep)

            tables[key] = self._pair_table("pattern_pairs", {"max_per_region": key[0],
                                                             "radius": key[1]}, build)
        return tables[key]

    @cached_property
    def triangles(self):
        """Triangles of the pattern stars (default thinning), by area and polar moment."""
        return self.triangle_table()

    def triangle_table(self, max_per_region: int | str | None = "auto",
                       region_radius_deg: float | None = None):
        """Triangles of the stars with fewer than ``max_per_region`` brighter stars within
        ``region_radius_deg`` (default half the FOV); "auto" fits a budget, None: all
        stars. See :mod:`startrack.database._triangles`."""
        radius = math.radians(region_radius_deg or self.camera.fov_deg / 2.0)
        arrays = self._cached(
            "triangles", {"max_per_region": max_per_region, "radius": round(radius, 9),
                          "budget": tri.TRIANGLE_BUDGET},
            lambda: tri.build_triangle_arrays(self.vectors, self.pairs.i, self.pairs.j,
                                              radius, max_per_region))
        return tri.triangle_table_from_arrays(arrays)

    @cached_property
    def cone_index(self) -> ConeIndex:
        """The z-sorted index behind :meth:`cone` (its arrays feed compiled lookups): the
        catalog's own (:func:`cone_index_of`), one whatever the databases of it."""
        return cone_index_of(self.catalog)

    def cone(self, direction: np.ndarray, radius_rad: float) -> np.ndarray:
        """Catalog rows within ``radius_rad`` of a unit vector, brightest first."""
        return self.cone_index.rows(direction, radius_rad)

    def radial(self, radius_rad: float, ring_width_rad: float):
        """Radial features of every catalog star (rings of ``ring_width_rad`` out to
        ``radius_rad``, at most the image diagonal); see :mod:`startrack.database._radial`."""
        radius_rad = min(float(radius_rad), self.max_angle_rad)
        key = (round(radius_rad, 12), round(float(ring_width_rad), 12))
        tables = self.__dict__.setdefault("_radial_tables", {})
        if key not in tables:
            arrays = self._cached("radial", {"radius": key[0], "ring_width": key[1]},
                                  lambda: build_radial_arrays(self.pairs, len(self.vectors),
                                                              *key))
            tables[key] = radial_table_from_arrays(arrays, *key)
        return tables[key]


__all__ = [
    "BIN", "binary_search_range", "build_threads", "cone_index_of", "CutCones", "EDGES",
    "feature_sigmas",
    "K_NEAREST", "KVector", "level_for", "level_stars", "LEVEL_STEP", "MAX_PATTERN_SIZE", "NBINS",
    "observed_masks", "PairTable", "PATTERN_SIZE", "quad_level", "QuadLevel", "RadialTable",
    "RATIO_STEPS", "StarDatabase", "held_cone_index", "triangle_features",
]

# Other stages' entry points, each imported on first use.
__getattr__, __dir__ = lazy_exports(__name__, {
    "BIN": "_quads",
    "EDGES": "_quads",
    "K_NEAREST": "_quads",
    "LEVEL_STEP": "_quads",
    "MAX_PATTERN_SIZE": "_quads",
    "NBINS": "_quads",
    "PATTERN_SIZE": "_quads",
    "QuadLevel": "_quads",
    "RATIO_STEPS": "_quads",
    "level_for": "_quads",
    "level_stars": "_quads",
    "quad_level": "_quads",
    "binary_search_range": "_kvector",
    "build_threads": "_pairs",
    "feature_sigmas": "_triangles",
    "observed_masks": "_radial",
    "RadialTable": "_radial",
    "triangle_features": "_triangles",
})
