"""The geometry the radial matcher's variants share: the improved triangle paper's ring
choice per frame, and the plain side-side-side triangle test over the pair table.

The paper (an improved triangle star identification with radial features, equation 3)
takes the ring radius R as the largest and the ring width dr as the smallest angular
distance among the extracted stars *and* among the navigation stars of the field:
``R = max(d(i, j), d_ijm)``, ``dr = min(d(i, j), d_ijm)``. Within a known sky patch the
navigation stars are the catalog stars of the patch; lost in space they are every catalog
star, whose tabled pairs span the whole field diagonal down to the closest double.
"""

from __future__ import annotations

import numpy as np

from startrack.matchers._shared.geometry import angle_table

_SELF_RAD = 1e-7  # a separation at (numerically) zero angle is a star with itself


def separation_range(vectors: np.ndarray) -> tuple[float, float]:
    """Largest and smallest separation (radians) among ``vectors`` (at least two)."""
    d = angle_table(vectors, vectors)[np.triu_indices(len(vectors), 1)]
    d = d[d > _SELF_RAD]
    if len(d) == 0:
        raise ValueError("the ring rule needs two distinct stars")
    return float(d.max()), float(d.min())


def field_rings(vectors: np.ndarray) -> tuple[float, float]:
    """R and dr from the observed stars alone: their largest and smallest separation
    (radians). Kept to compare with the paper's rule, which adds the navigation stars."""
    return separation_range(vectors)


def paper_rings(observed: np.ndarray, navigation: tuple[float, float]) -> tuple[float, float]:
    """The paper's equation 3: R the largest and dr the smallest of the observed stars'
    separations and the navigation stars' (``navigation`` = their (largest, smallest))."""
    obs_max, obs_min = separation_range(observed)
    return max(obs_max, navigation[0]), min(obs_min, navigation[1])


def catalog_range(pairs) -> tuple[float, float]:
    """(largest, smallest) separation of the catalog's tabled pairs: the navigation stars'
    range when the sky patch is unknown (every catalog star is a navigation star)."""
    angle = pairs.angle[pairs.angle > _SELF_RAD]
    return float(angle.max()), float(angle.min())


def pair_triangles(pairs, obs_d: np.ndarray, a: int, b: int, c: int,
                   eps: float) -> np.ndarray:
    """Catalog triangles (K x 3 rows, in a, b, c order) whose three sides match the
    observed ones within ``eps``: side-side-side over every catalog star (pair table)."""
    def both(p: int, q: int) -> tuple[np.ndarray, np.ndarray]:
        i, j, _ = pairs.query(obs_d[p, q] - eps, obs_d[p, q] + eps)
        i, j = i.astype(np.int64), j.astype(np.int64)
        return np.concatenate([i, j]), np.concatenate([j, i])

    ab_i, ab_j = both(a, b)
    bc_i, bc_j = both(b, c)
    order = np.argsort(bc_i, kind="stable")
    lo = np.searchsorted(bc_i[order], ab_j, side="left")
    count = np.searchsorted(bc_i[order], ab_j, side="right") - lo
    rows = np.repeat(np.arange(len(ab_i)), count)
    pos = np.repeat(lo - np.cumsum(count) + count, count) + np.arange(int(count.sum()))
    tri = np.column_stack([ab_i[rows], ab_j[rows], bc_j[order[pos]]])
    tri = tri[tri[:, 0] != tri[:, 2]]
    ac_i, ac_j = both(a, c)
    base = int(max(tri.max(initial=0), ac_j.max(initial=0))) + 1
    return tri[np.isin(tri[:, 0] * base + tri[:, 2], ac_i * base + ac_j)]


def dense_triangles(cat_a: np.ndarray, cat_b: np.ndarray, cat_c: np.ndarray,
                    obs_d: np.ndarray, stars: tuple[int, int, int], eps: float):
    """Side-side-side over three candidate lists (their catalog vectors): positions
    (ia, ib, ic) in the lists of every triangle whose three sides match within ``eps``."""
    a, b, c = stars
    ab = np.abs(angle_table(cat_a, cat_b) - obs_d[a, b]) <= eps
    if not ab.any():
        return None
    bc = np.abs(angle_table(cat_b, cat_c) - obs_d[b, c]) <= eps
    ac = np.abs(angle_table(cat_a, cat_c) - obs_d[a, c]) <= eps
    found = np.nonzero(ab[:, :, None] & bc[None, :, :] & ac[:, None, :])
    return found if len(found[0]) else None
