"""Scale-free four-star patterns of the catalog, one table per field-of-view level.

A pattern is four stars; its key is the five smaller of its six pair angles divided by
the largest, sorted and quantised, so the key does not depend on the focal length and
a match gives the image scale (the largest edge in pixels against the same edge on the
sky). The sky is covered at levels of field of view ``F`` a factor sqrt(2) apart: at
each level the pattern stars are the brightest stars, as many as give
``STARS_PER_FRAME`` in an average frame (all of a catalog that holds fewer), and every
four pattern stars whose edges are all within ``PATTERN_SIZE * F`` make a pattern. The
brightest stars of an image are then mostly pattern stars, wherever it points. A frame of field
of view F is searched in the level nearest F.
Each level is built once and cached (:func:`startrack.cache.cached_arrays`).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from scipy.spatial import cKDTree

from startrack.cache import cached_arrays

STARS_PER_FRAME = 25  # pattern stars in an average frame of a level's FOV
PATTERN_SIZE = 0.4  # largest pattern edge, in level FOVs
MAX_HIGHER = 8  # fainter pattern stars each pattern star combines with, at most
BIN = 0.025  # key quantisation step of an edge ratio (at least twice the lookup tolerance)
NBINS = int(round(1.0 / BIN))
LEVEL_STEP = math.sqrt(2.0)
FORMAT_VERSION = 1
#: pair (a, b) of each of the six edges of a pattern (a < b, rows of a 4-star pattern)
EDGES = np.array([(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)])


def level_for(fov_deg: float) -> float:
    """The level (a power of sqrt 2, in degrees) nearest ``fov_deg``."""
    return float(LEVEL_STEP ** round(math.log(fov_deg) / math.log(LEVEL_STEP)))


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


@njit(cache=True)
def _dot(v, a, b):
    return v[a, 0] * v[b, 0] + v[a, 1] * v[b, 1] + v[a, 2] * v[b, 2]


@njit(cache=True)
def _enumerate(indptr, indices, vectors, cos_max, out):
    """Every pattern (a, b, c, d), a < b < c < d, with b, c, d among the higher
    neighbours of a and every edge within the angle whose cosine is ``cos_max``; writes
    them to ``out`` when it is large enough and returns how many there are."""
    m = 0
    for a in range(len(indptr) - 1):
        lo, hi = indptr[a], min(indptr[a + 1], indptr[a] + MAX_HIGHER)
        for i in range(lo, hi):
            b = indices[i]
            for j in range(i + 1, hi):
                c = indices[j]
                if _dot(vectors, b, c) < cos_max:
                    continue
                for k in range(j + 1, hi):
                    d = indices[k]
                    if _dot(vectors, b, d) < cos_max or _dot(vectors, c, d) < cos_max:
                        continue
                    if m < out.shape[0]:
                        out[m, 0], out[m, 1], out[m, 2], out[m, 3] = a, b, c, d
                    m += 1
    return m


def all_quads(vectors: np.ndarray, max_edge_rad: float) -> np.ndarray:
    """Every four rows of ``vectors`` whose six edges are at most ``max_edge_rad``, each
    row combining with at most the first ``MAX_HIGHER`` later rows near it (rows are
    brightest first, so a crowded field keeps its brighter patterns)."""
    n = len(vectors)
    if n < 4:
        return np.zeros((0, 4), np.int64)
    chord = 2.0 * math.sin(max_edge_rad / 2.0)
    pairs = cKDTree(vectors).query_pairs(chord, output_type="ndarray")
    if len(pairs) == 0:
        return np.zeros((0, 4), np.int64)
    pairs = np.sort(pairs, axis=1)
    pairs = pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]
    indptr = np.zeros(n + 1, np.int64)
    np.cumsum(np.bincount(pairs[:, 0], minlength=n), out=indptr[1:])
    indices = np.ascontiguousarray(pairs[:, 1], np.int64)
    v = np.ascontiguousarray(vectors, np.float64)
    cos_max = math.cos(max_edge_rad)
    m = _enumerate(indptr, indices, v, cos_max, np.zeros((0, 4), np.int64))
    out = np.zeros((m, 4), np.int64)
    _enumerate(indptr, indices, v, cos_max, out)
    return out


def level_stars(level_deg: float) -> int:
    """How many of the brightest stars make patterns at a level: ``STARS_PER_FRAME`` in
    an average frame ``level_deg`` wide with the 4:3 shape of most sensors."""
    frame_sr = math.radians(level_deg) ** 2 * 0.75
    return int(STARS_PER_FRAME * 4.0 * math.pi / frame_sr)


def build_level_arrays(vectors: np.ndarray, level_deg: float) -> dict[str, np.ndarray]:
    """The pattern table of one level: keys (sorted, int32: NBINS**5 < 2**31) and quads
    (rows of ``vectors``, which are brightest first)."""
    head = vectors[: min(len(vectors), level_stars(level_deg))]
    quads = all_quads(head, PATTERN_SIZE * math.radians(level_deg))
    r, _ = ratios(edge_angles(head, quads))
    keys = keys_of(r)
    order = np.argsort(keys, kind="stable")
    return {"keys": keys[order].astype(np.int32), "quads": quads[order].astype(np.int32)}


class QuadLevel:
    """One level's table, looked up by key ranges."""

    def __init__(self, level_deg: float, arrays: dict[str, np.ndarray]) -> None:
        self.level_deg = level_deg
        self.keys = arrays["keys"].astype(np.int64)
        self.quads = arrays["quads"]

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
              "stars": STARS_PER_FRAME, "size": PATTERN_SIZE, "k": MAX_HIGHER, "bin": BIN,
              "v": FORMAT_VERSION}
    arrays = cached_arrays("quads", params,
                           lambda: build_level_arrays(catalog.vectors, level_deg))
    return QuadLevel(level_deg, arrays)
