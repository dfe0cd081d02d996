"""Catalog star triangles by planar area and polar moment (Cole and Crassidis, 2006).

Three unit vectors b1, b2, b3 span the planar triangle through their tips, with chord
sides a = |b1 - b2|, b = |b2 - b3|, c = |b1 - b3|. Its area A (Heron) and polar moment
J = A (a^2 + b^2 + c^2) / 36 describe it far better than one angle. The table holds every
triplet of *pattern stars* whose three sides are within the database's largest angle
(the image diagonal: the paper's "all sides fit in the field of view"), sorted by area
with a k-vector over it.

Pattern stars bound the table's size: on a dense sky (Hipparcos Hp <= 6.5 at 20 deg) every
star has hundreds of neighbours and the full table would hold hundreds of millions of
triangles. As in tetra3, a star is kept only when fewer than ``max_per_region`` brighter
stars lie within ``region_radius`` (by default half the horizontal FOV) of it, so each
region of the sky keeps its brightest stars, the ones a frame's brightest stars are.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from startrack._core.database import builds as kernels
from startrack.database._kvector import KVector

# The default cap on the table: the random 2000-star sky at 17.5 deg needs no thinning
# (1.6 M triangles); Hipparcos Hp <= 6.5 at 20 deg gets a cap of 15 (1968 stars, 2.5 M).
TRIANGLE_BUDGET = 3_000_000


def _cross(u: np.ndarray, w: np.ndarray) -> np.ndarray:
    # np.cross costs ~30 us of overhead per call, which dominates small per-frame batches.
    return np.stack([u[..., 1] * w[..., 2] - u[..., 2] * w[..., 1],
                     u[..., 2] * w[..., 0] - u[..., 0] * w[..., 2],
                     u[..., 0] * w[..., 1] - u[..., 1] * w[..., 0]], axis=-1)


def _sides(v1: np.ndarray, v2: np.ndarray, v3: np.ndarray) -> tuple[np.ndarray, ...]:
    return (np.linalg.norm(v1 - v2, axis=-1), np.linalg.norm(v2 - v3, axis=-1),
            np.linalg.norm(v1 - v3, axis=-1))


def triangle_features(v1: np.ndarray, v2: np.ndarray,
                      v3: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(area, polar_moment) of the planar triangles through unit vectors (..., 3).

    The area is Heron's on the chord sides; it is computed as half the norm of the cross
    product of two edges, which is the same number but keeps its accuracy for thin
    triangles where Heron's product cancels.
    """
    v1, v2, v3 = (np.asarray(v, dtype=np.float64) for v in (v1, v2, v3))
    area = 0.5 * np.linalg.norm(_cross(v2 - v1, v3 - v1), axis=-1)
    a, b, c = _sides(v1, v2, v3)
    return area, area * (a * a + b * b + c * c) / 36.0


def _tangent_basis(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors orthogonal to each unit vector in ``v`` (..., 3) and to each other."""
    helper = np.zeros_like(v)
    axis = np.argmin(np.abs(v), axis=-1)
    np.put_along_axis(helper, axis[..., None], 1.0, axis=-1)
    t1 = _cross(v, helper)
    t1 /= np.linalg.norm(t1, axis=-1, keepdims=True)
    return t1, _cross(v, t1)


def feature_sigmas(v1: np.ndarray, v2: np.ndarray, v3: np.ndarray,
                   sigma_rad: float) -> tuple[np.ndarray, np.ndarray]:
    """1-sigma errors of (area, polar_moment) when each vector errs by ``sigma_rad`` per
    tangent axis, independently.

    First-order propagation, as Cole and Crassidis do analytically, but with the gradient
    taken numerically: central differences along the 6 tangent-plane directions (two per
    vertex), vectorised over all triangles.
    """
    verts = [np.asarray(v, dtype=np.float64) for v in (v1, v2, v3)]
    h = 1e-6
    var_a = np.zeros(verts[0].shape[:-1])
    var_j = np.zeros_like(var_a)
    for n in range(3):
        for t in _tangent_basis(verts[n]):
            plus, minus = list(verts), list(verts)
            plus[n] = verts[n] + h * t
            minus[n] = verts[n] - h * t
            ap, jp = triangle_features(*plus)
            am, jm = triangle_features(*minus)
            var_a += ((ap - am) / (2 * h)) ** 2
            var_j += ((jp - jm) / (2 * h)) ** 2
    return sigma_rad * np.sqrt(var_a), sigma_rad * np.sqrt(var_j)


@dataclass(frozen=True)
class TriangleTable:
    """Catalog triangles sorted by area. ``rows[t]`` are the catalog rows of triangle t,
    ordered by the length of the opposite side (vertex 0 faces the shortest side)."""

    area: np.ndarray  # float64, ascending
    polar: np.ndarray  # float64
    rows: np.ndarray  # int32 (M, 3)
    pattern: np.ndarray  # int32 catalog rows of the pattern stars
    max_per_region: int | None  # the cap that chose them (None: every star)
    kvector: KVector

    def __len__(self) -> int:
        return len(self.area)

    def query(self, area_lo: float, area_hi: float, polar_lo: float = -np.inf,
              polar_hi: float = np.inf) -> tuple[np.ndarray, int]:
        """Indices of the triangles with area in [area_lo, area_hi] (k-vector) and polar
        moment in [polar_lo, polar_hi], and the count of the area lookup alone."""
        start, stop = self.kvector.range(area_lo, area_hi)
        j = self.polar[start:stop]
        return start + np.flatnonzero((j >= polar_lo) & (j <= polar_hi)), stop - start


def brighter_neighbours(vectors: np.ndarray, radius_rad: float) -> np.ndarray:
    """For each row, how many brighter stars lie within ``radius_rad`` (rows are sorted
    brightest first, so "brighter" is "smaller row")."""
    n = len(vectors)
    chord = 2.0 * math.sin(radius_rad / 2.0)
    close = cKDTree(vectors).query_pairs(chord, output_type="ndarray") if n else []
    if len(close) == 0:
        return np.zeros(n, np.int64)
    return np.bincount(np.max(close, axis=1), minlength=n)


def auto_max_per_region(brighter: np.ndarray, pair_i: np.ndarray, pair_j: np.ndarray,
                        budget: int = TRIANGLE_BUDGET) -> int | None:
    """The largest cap whose table fits ``budget`` triangles (None: no cap needed).

    With N pattern stars and P pairs among them the table holds about 0.4 P^2 / N
    triangles (measured 0.39 +- 0.01 on both test skies: the chance that two neighbours
    of a star are neighbours of each other, over 3 vertices), so every cap is costed from
    two cumulative histograms without building anything.
    """
    if len(brighter) == 0:
        return None
    top = int(brighter.max()) + 2
    n_stars = np.cumsum(np.bincount(brighter, minlength=top))
    level = np.maximum(brighter[pair_i], brighter[pair_j])
    n_pairs = np.cumsum(np.bincount(level, minlength=top))
    estimate = 0.4 * n_pairs.astype(float) ** 2 / np.maximum(n_stars, 1)
    if estimate[-1] <= budget:
        return None
    fits = np.flatnonzero(estimate <= budget)  # estimate[k - 1]: stars with < k brighter
    return int(fits[-1]) + 1 if len(fits) else 1


def build_triangle_arrays(vectors: np.ndarray, pair_i: np.ndarray, pair_j: np.ndarray,
                          region_radius_rad: float, max_per_region: int | str | None = "auto",
                          budget: int = TRIANGLE_BUDGET) -> dict[str, np.ndarray]:
    """Triangles of pattern stars whose three sides are catalog pairs (all pairs closer
    than the database's largest angle), sorted by area.

    Pattern stars have fewer than ``max_per_region`` brighter stars within
    ``region_radius_rad``; "auto" takes the largest cap that fits ``budget``; None keeps
    every star.
    """
    n = len(vectors)
    brighter = brighter_neighbours(vectors, region_radius_rad)
    if max_per_region == "auto":
        max_per_region = auto_max_per_region(brighter, pair_i, pair_j, budget)
    cap = n + 1 if max_per_region is None else int(max_per_region)
    pattern = np.flatnonzero(brighter < cap)
    is_pattern = np.zeros(n, bool)
    is_pattern[pattern] = True
    sel = is_pattern[pair_i] & is_pattern[pair_j]
    lo = np.minimum(pair_i[sel], pair_j[sel])
    hi = np.maximum(pair_i[sel], pair_j[sel])
    tri, area, polar = kernels.triangles_of_pairs(
        n, lo.astype(np.int64), hi.astype(np.int64),
        np.ascontiguousarray(vectors, dtype=np.float64).reshape(-1, 3))
    order = kernels.stable_argsort(area, 0.0, float(area.max()) if len(area) else 1.0)
    tri, area, polar = kernels.take_triangles(order, tri, area, polar)
    return {"area": area, "polar": polar, "rows": tri,
            "pattern": pattern.astype(np.int32),
            "max_per_region": np.array(-1 if max_per_region is None else cap)}


def triangle_table_from_arrays(arrays: dict[str, np.ndarray]) -> TriangleTable:
    cap = int(arrays["max_per_region"])
    return TriangleTable(arrays["area"], arrays["polar"], arrays["rows"], arrays["pattern"],
                         None if cap < 0 else cap, KVector.build(arrays["area"]))

__all__ = [
    "TRIANGLE_BUDGET", "TriangleTable", "auto_max_per_region", "brighter_neighbours",
    "build_triangle_arrays", "feature_sigmas", "triangle_features", "triangle_table_from_arrays",
]
