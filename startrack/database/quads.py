"""Scale-free four-star patterns of the catalog, one table per field-of-view level.

A pattern is four stars; its key is the five smaller of its six pair angles divided by
the largest, sorted and quantised, so the key does not depend on the focal length and
a match gives the image scale (the largest edge in pixels against the same edge on the
sky). The sky is covered at levels of field of view ``F`` a factor sqrt(2) apart: at
each level the pattern stars are the catalog thinned brightest first to a minimum
separation of ``SEPARATION * F`` (about 15 to 30 per frame), and each pattern star makes
patterns with every three of its ``NEIGHBOURS`` nearest pattern stars within
``PATTERN_SIZE * F``. A frame of field of view F is searched in the level nearest F.
Each level is built once and cached (:func:`startrack.cache.cached_arrays`).
"""

from __future__ import annotations

import itertools
import math

import numpy as np
from numba import njit
from scipy.spatial import cKDTree

from startrack.cache import cached_arrays

SEPARATION = 0.2  # minimum separation of pattern stars, in level FOVs
PATTERN_SIZE = 0.6  # largest pattern edge, in level FOVs
NEIGHBOURS = 5  # nearest pattern stars a pattern star combines with
BIN = 0.02  # key quantisation step of an edge ratio
NBINS = int(round(1.0 / BIN))
LEVEL_STEP = math.sqrt(2.0)
FORMAT_VERSION = 1
#: pair (a, b) of each of the six edges of a pattern (a < b, rows of a 4-star pattern)
EDGES = np.array([(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)])


def level_for(fov_deg: float) -> float:
    """The level (a power of sqrt 2, in degrees) nearest ``fov_deg``."""
    return float(LEVEL_STEP ** round(math.log(fov_deg) / math.log(LEVEL_STEP)))


@njit(cache=True)
def _greedy_keep(n: int, pairs: np.ndarray) -> np.ndarray:
    """Keep row b unless a kept brighter row a is within the separation; ``pairs`` (a < b)
    sorted by a, so a's fate is settled before its pairs are read."""
    keep = np.ones(n, np.bool_)
    for k in range(pairs.shape[0]):
        if keep[pairs[k, 0]]:
            keep[pairs[k, 1]] = False
    return keep


def thin(vectors: np.ndarray, separation_rad: float) -> np.ndarray:
    """Rows (brightest first) with no brighter kept row within ``separation_rad``."""
    if len(vectors) < 2:
        return np.arange(len(vectors))
    chord = 2.0 * math.sin(separation_rad / 2.0)
    pairs = cKDTree(vectors).query_pairs(chord, output_type="ndarray")
    if len(pairs) == 0:
        return np.arange(len(vectors))
    pairs = np.sort(pairs, axis=1)
    pairs = np.ascontiguousarray(pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))], np.int64)
    return np.flatnonzero(_greedy_keep(len(vectors), pairs))


def edge_angles(vectors: np.ndarray, quads: np.ndarray) -> np.ndarray:
    """The six pair angles (M x 6, radians) of each pattern (M x 4 rows of ``vectors``)."""
    a = vectors[quads[:, EDGES[:, 0]]]
    b = vectors[quads[:, EDGES[:, 1]]]
    chord = np.linalg.norm(a - b, axis=-1)
    return 2.0 * np.arcsin(np.clip(chord / 2.0, 0.0, 1.0))


def ratios(edges: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Sorted edges divided by the largest (M x 5) and the largest edge (M)."""
    s = np.sort(edges, axis=1)
    largest = s[:, 5]
    return s[:, :5] / np.where(largest > 0, largest, 1.0)[:, None], largest


def keys_of(r: np.ndarray) -> np.ndarray:
    """The int64 key of each row of quantised ratios."""
    q = np.clip((r / BIN).astype(np.int64), 0, NBINS - 1)
    return (q * (NBINS ** np.arange(5))).sum(axis=1)


def neighbour_quads(vectors: np.ndarray, centres: np.ndarray, max_edge_rad: float,
                    k: int) -> np.ndarray:
    """Patterns (M x 4, sorted rows, unique) of each centre row with every three of its
    ``k`` nearest other rows within ``max_edge_rad``, every edge at most that long."""
    n = len(vectors)
    if n < 4 or len(centres) == 0:
        return np.zeros((0, 4), np.int64)
    k = min(k, n - 1)
    chord = 2.0 * math.sin(max_edge_rad / 2.0)
    _, near = cKDTree(vectors).query(vectors[centres], k=k + 1, distance_upper_bound=chord)
    near = near.reshape(len(centres), k + 1)[:, 1:]
    combos = np.array(list(itertools.combinations(range(k), 3)))
    quads = np.concatenate([np.repeat(centres[:, None], len(combos), 0).reshape(-1, 1),
                            near[:, combos].reshape(-1, 3)], axis=1)
    quads = quads[np.all(quads < n, axis=1)]
    if len(quads) == 0:
        return np.zeros((0, 4), np.int64)
    quads = np.unique(np.sort(quads, axis=1), axis=0)
    edges = edge_angles(vectors, quads)
    return quads[edges.max(axis=1) <= max_edge_rad]


def build_level_arrays(vectors: np.ndarray, level_deg: float) -> dict[str, np.ndarray]:
    """The pattern table of one level: keys (sorted), quads (rows of ``vectors``, which
    are brightest first) and the largest edge of each pattern in radians."""
    level = math.radians(level_deg)
    sep = SEPARATION * level
    # Greedy thinning keeps about one star per 1.6 sep^2 of sky; the brightest eight
    # times that many stars are plenty to choose from, and bound the pair search.
    wanted = int(4.0 * math.pi / (1.6 * sep * sep))
    head = vectors[: min(len(vectors), 8 * wanted)]
    rows = thin(head, sep)
    quads = neighbour_quads(head[rows], np.arange(len(rows)), PATTERN_SIZE * level,
                            NEIGHBOURS)
    r, largest = ratios(edge_angles(head[rows], quads))
    keys = keys_of(r)
    order = np.argsort(keys, kind="stable")
    return {"keys": keys[order], "quads": rows[quads[order]].astype(np.int32),
            "largest": largest[order].astype(np.float32)}


class QuadLevel:
    """One level's table, looked up by key ranges."""

    def __init__(self, level_deg: float, arrays: dict[str, np.ndarray]) -> None:
        self.level_deg = level_deg
        self.keys = arrays["keys"]
        self.quads = arrays["quads"]
        self.largest = arrays["largest"]

    def __len__(self) -> int:
        return len(self.keys)

    def lookup(self, keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """For each query key, the table rows holding it: (query index, table row)."""
        lo = np.searchsorted(self.keys, keys, side="left")
        hi = np.searchsorted(self.keys, keys, side="right")
        counts = hi - lo
        query = np.repeat(np.arange(len(keys)), counts)
        offset = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
        return query, np.repeat(lo, counts) + offset


def quad_level(catalog, level_deg: float) -> QuadLevel:
    """The cached pattern table of ``catalog`` at one level."""
    params = {"catalog": catalog.fingerprint(), "level": round(level_deg, 9),
              "sep": SEPARATION, "size": PATTERN_SIZE, "k": NEIGHBOURS, "bin": BIN,
              "v": FORMAT_VERSION}
    arrays = cached_arrays("quads", params,
                           lambda: build_level_arrays(catalog.vectors, level_deg))
    return QuadLevel(level_deg, arrays)
