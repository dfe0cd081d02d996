"""Scale-free four-star patterns of the catalog, one table per field-of-view level.

A pattern is four stars; its key is the five smaller of its six pair angles divided by
the largest, sorted and quantised, so the key does not depend on the focal length and
a match gives the image scale (the largest edge in pixels against the same edge on the
sky). The sky is covered at levels of field of view ``F`` a factor sqrt(2) apart: at
each level the pattern stars are the brightest stars, as many as give
``STARS_PER_FRAME`` in an average frame (all of a catalog that holds fewer), and every
four pattern stars whose edges are all within ``PATTERN_SIZE * F`` make a pattern. Where
the pattern stars are sparse (a narrow field whose catalog runs out, a galactic pole) a
star's patterns reach out to its ``K_NEAREST`` nearest pattern stars, up to the frame
diagonal (``MAX_PATTERN_SIZE * F``): a sparse frame's few stars still make patterns that
the table holds. The brightest stars of an image are then mostly pattern stars, wherever
it points. A frame of field of view F is searched in the level nearest F.
Each level is built once and cached (:func:`startrack.io._cache.cached_arrays`).
"""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np
from scipy.spatial import cKDTree

from startrack._core._threads import usable_cores
from startrack._core.database.quad_table import enumerate_quads, pattern_keys
from startrack.io import cached_arrays

STARS_PER_FRAME = 25  # pattern stars in an average frame of a level's FOV
PATTERN_SIZE = 0.4  # largest pattern edge, in level FOVs
MAX_HIGHER = 8  # fainter pattern stars each pattern star combines with, at most
#: a star in a sparse patch makes patterns with its this many nearest pattern stars
K_NEAREST = 8
MAX_PATTERN_SIZE = 1.25  # largest pattern edge where stars are sparse: a 4:3 diagonal
BIN = 0.025  # key quantisation step of an edge ratio (at least twice the lookup tolerance)
NBINS = int(round(1.0 / BIN))
LEVEL_STEP = math.sqrt(2.0)
RATIO_STEPS = 255  # a table's ratios are stored as uint8 in steps of 1/RATIO_STEPS
FORMAT_VERSION = 4
#: pair (a, b) of each of the six edges of a pattern (a < b, rows of a 4-star pattern)
EDGES = np.array([(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)])
#: pattern stars whose neighbours and patterns a build holds at once
BUILD_CHUNK_STARS = 1 << 16


def level_for(fov_deg: float) -> float:
    """The level (a power of sqrt 2, in degrees) nearest ``fov_deg``."""
    return float(LEVEL_STEP ** round(math.log(fov_deg) / math.log(LEVEL_STEP)))


def _chord(angle_rad: float) -> float:
    return 2.0 * math.sin(min(angle_rad, math.pi) / 2.0)


def pattern_radii(vectors: np.ndarray, min_rad: float, max_rad: float,
                  k: int = K_NEAREST, rows: slice = slice(None),
                  tree: cKDTree | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Each row's largest pattern edge (radians): ``min_rad``, or where stars are sparse
    the angle to its ``k``-th nearest other row, at most ``max_rad``; and the rows within
    that angle of each row whose radius exceeds ``min_rad`` (N x k, ``len(vectors)`` where
    there is none). ``rows``: only these rows' (a build's chunk); ``tree``: the k-d tree of
    ``vectors``, when one is built already."""
    n = len(vectors)
    heads = vectors[rows]
    kk = min(k, n - 1)
    if kk <= 0 or max_rad <= min_rad:
        return np.full(len(heads), float(min_rad)), np.full((len(heads), 0), n, np.int64)
    tree = cKDTree(vectors) if tree is None else tree
    dist, near = tree.query(heads, k=kk + 1, distance_upper_bound=_chord(max_rad),
                            workers=usable_cores())
    kth = dist[:, -1]
    angle = np.where(np.isfinite(kth), 2.0 * np.arcsin(np.clip(kth / 2.0, 0.0, 1.0)),
                     max_rad)
    radii = np.clip(angle, min_rad, max_rad)
    near = np.where(radii[:, None] > min_rad, near[:, 1:], n)
    return radii, near


def _neighbour_lists(vectors: np.ndarray, min_rad: float, sparse_rows: np.ndarray,
                     rows: slice = slice(None), tree: cKDTree | None = None):
    """CSR lists of each row's higher rows within its pattern radius: the pairs within
    ``min_rad`` and the rows of :func:`pattern_radii` beyond it (``sparse_rows``, of the
    same ``rows``). ``rows``: a contiguous range of rows (a build's chunk), whose lists
    alone are made, with the others' row numbers."""
    n = len(vectors)
    first, stop, _ = rows.indices(n)
    tree = cKDTree(vectors) if tree is None else tree
    near = tree.query_ball_point(vectors[first:stop], _chord(min_rad), workers=usable_cores(),
                                 return_sorted=False)
    counts = np.fromiter(map(len, near), np.int64, len(near))
    head_p = np.repeat(np.arange(first, stop, dtype=np.int64), counts)
    other_p = np.concatenate([np.asarray(r, np.int64) for r in near]) if len(near) else \
        np.zeros(0, np.int64)
    del near
    higher = other_p > head_p
    head = np.repeat(np.arange(first, stop, dtype=np.int64), sparse_rows.shape[1])
    other = sparse_rows.ravel().astype(np.int64)
    far = (other < n) & (other > head)
    # one int64 code per (head, higher row): sorted, by head, then by brightness (a sort
    # and a comparison: numpy's hashing np.unique is several times slower on these)
    code = np.concatenate([head_p[higher] * n + other_p[higher], head[far] * n + other[far]])
    code.sort()
    code = code[np.concatenate([[True], code[1:] != code[:-1]])] if len(code) else code
    indptr = np.zeros(stop - first + 1, np.int64)
    np.cumsum(np.bincount(code // n - first, minlength=stop - first), out=indptr[1:])
    return indptr, np.ascontiguousarray(code % n, np.int64)


def quad_chunks(vectors: np.ndarray, max_edge_rad: float, sparse_edge_rad: float = 0.0,
                max_higher: int = MAX_HIGHER, k: int = K_NEAREST,
                chunk: int = BUILD_CHUNK_STARS) -> Iterator[np.ndarray]:
    """:func:`all_quads`, ``chunk`` first rows at a time (in the same order): memory held
    by a build grows with a chunk's pairs, not with the whole sky's."""
    n = len(vectors)
    if n < 4:
        return
    v = np.ascontiguousarray(vectors, np.float64)
    tree = cKDTree(v)
    for first in range(0, n, chunk):
        rows = slice(first, min(n, first + chunk))
        radii, sparse_rows = pattern_radii(v, max_edge_rad, sparse_edge_rad, k, rows, tree)
        indptr, indices = _neighbour_lists(v, max_edge_rad, sparse_rows, rows, tree)
        if len(indices) == 0:
            continue
        # a sparse star's pattern lies in the disk out to its k-th nearest star: edges
        # between its neighbours reach across that disk
        sparse = radii > max_edge_rad
        cos_max = np.cos(np.where(sparse, np.minimum(2.0 * radii, max(sparse_edge_rad,
                                                                      max_edge_rad)), radii))
        cap = np.where(sparse, max(k, max_higher), max_higher).astype(np.int64)
        quads = enumerate_quads(indptr, indices, v, np.ascontiguousarray(cos_max), cap)
        quads[:, 0] += first
        yield quads


def all_quads(vectors: np.ndarray, max_edge_rad: float, sparse_edge_rad: float = 0.0,
              max_higher: int = MAX_HIGHER, k: int = K_NEAREST) -> np.ndarray:
    """Every four rows of ``vectors`` whose six edges are at most the first row's pattern
    radius (:func:`pattern_radii`: ``max_edge_rad``, up to ``sparse_edge_rad`` where rows
    are sparse), each row combining with at most the first ``max_higher`` later rows near
    it (rows are brightest first, so a crowded field keeps its brighter patterns); a
    sparse row reaches its ``k`` nearest rows and combines with every later one of them."""
    parts = list(quad_chunks(vectors, max_edge_rad, sparse_edge_rad, max_higher, k))
    return np.concatenate(parts) if parts else np.zeros((0, 4), np.int64)


def level_stars(level_deg: float) -> int:
    """How many of the brightest stars make patterns at a level: ``STARS_PER_FRAME`` in
    an average frame ``level_deg`` wide with the 4:3 shape of most sensors."""
    frame_sr = math.radians(level_deg) ** 2 * 0.75
    return int(STARS_PER_FRAME * 4.0 * math.pi / frame_sr)


def build_level_arrays(vectors: np.ndarray, level_deg: float) -> dict[str, np.ndarray]:
    """The pattern table of one level: keys (sorted, int32: NBINS**5 < 2**31), quads
    (rows of ``vectors``, which are brightest first) and the ratios in ``RATIO_STEPS``
    (a first test of a lookup's candidates that needs no star of the catalog)."""
    head = vectors[: min(len(vectors), level_stars(level_deg))]
    key_parts, quad_parts, ratio_parts = [], [], []
    # Chunk by chunk, each pattern's key compiled (startrack._core.database.quad_table):
    # the whole table's patterns at once would hold GBs for a deep catalog's narrow level.
    v = np.ascontiguousarray(head, np.float64)
    for part in quad_chunks(head, PATTERN_SIZE * math.radians(level_deg),
                            MAX_PATTERN_SIZE * math.radians(level_deg)):
        keys, stored = pattern_keys(v, np.ascontiguousarray(part, np.int64), EDGES, BIN,
                                    NBINS, float(RATIO_STEPS))
        key_parts.append(keys)
        quad_parts.append(part.astype(np.int32))
        ratio_parts.append(stored)
    if not key_parts:
        return {"keys": np.zeros(0, np.int32), "quads": np.zeros((0, 4), np.int32),
                "ratios": np.zeros((0, 5), np.uint8)}
    # one array at a time, each part list let go as soon as it is joined: the peak is
    # about two copies of the largest array (the quads), not of the whole table
    keys = np.concatenate(key_parts)
    del key_parts
    order = np.argsort(keys, kind="stable")
    table = {"keys": keys[order]}
    del keys
    for name, parts in (("quads", quad_parts), ("ratios", ratio_parts)):
        joined = np.concatenate(parts)
        parts.clear()
        table[name] = joined[order]
        del joined
    return table


class QuadLevel:
    """One level's table: keys, quads and stored ratios, looked up by the compiled search
    (:func:`startrack.matchers._quad.compiled_table`)."""

    def __init__(self, level_deg: float, arrays: dict[str, np.ndarray]) -> None:
        self.level_deg = level_deg
        self.keys = arrays["keys"]  # int32 as stored: a large level is mapped, not copied
        self.quads = arrays["quads"]
        self.ratios = arrays["ratios"]

    def __len__(self) -> int:
        return len(self.keys)


def quad_level(catalog, level_deg: float) -> QuadLevel:
    """The cached pattern table of ``catalog`` at one level."""
    # keyed by the pattern stars alone: the magnitude cuts that hold them share the table
    head = min(len(catalog), level_stars(level_deg))
    params = {"catalog": catalog.fingerprint(head), "head": head, "level": round(level_deg, 9),
              "stars": STARS_PER_FRAME, "size": PATTERN_SIZE, "k": MAX_HIGHER, "bin": BIN,
              "near": K_NEAREST, "sparse": MAX_PATTERN_SIZE,
              "v": FORMAT_VERSION}
    arrays = cached_arrays("quads", params,
                           lambda: build_level_arrays(catalog.vectors[:head], level_deg))
    return QuadLevel(level_deg, arrays)

__all__ = [
    "BIN", "EDGES", "FORMAT_VERSION", "K_NEAREST", "LEVEL_STEP", "MAX_HIGHER",
    "MAX_PATTERN_SIZE", "NBINS", "PATTERN_SIZE", "QuadLevel", "RATIO_STEPS", "STARS_PER_FRAME",
    "all_quads", "build_level_arrays", "level_for", "level_stars", "pattern_radii",
    "quad_level",
]
