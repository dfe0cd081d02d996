"""The numpy quad search of one window that the compiled ``_core.matchers.quad.match_window``
replaced, kept to hold it to: the image's patterns by the table builder's k-d tree rule,
the key lookup by searchsorted of the 32 neighbouring keys, the sorted-ratio first test,
the best of the 24 star orders, the ranking by edge agreement; and the numpy pattern key
that the compiled ``_core.database.quad_table.pattern_keys`` replaced."""

from __future__ import annotations

import itertools
import math

import numpy as np

from startrack.database import _quads as Q
from startrack.matchers._quad import (
    IMAGE_NEAREST,
    IMAGE_STARS,
    MAX_CANDIDATES,
    PERM_EDGES,
    PERMS,
    RATIO_TOLERANCE,
)


def edge_angles(vectors: np.ndarray, quads: np.ndarray) -> np.ndarray:
    """The six pair angles (M x 6, radians) of each pattern (M x 4 rows of ``vectors``)."""
    a = vectors[quads[:, Q.EDGES[:, 0]]]
    b = vectors[quads[:, Q.EDGES[:, 1]]]
    chord = np.linalg.norm(a - b, axis=-1)
    return 2.0 * np.arcsin(np.clip(chord / 2.0, 0.0, 1.0))


def ratios(edges: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Sorted edges divided by the largest (M x 5) and the largest edge (M)."""
    s = np.sort(edges, axis=1)
    largest = s[:, 5]
    return s[:, :5] / np.where(largest > 0, largest, 1.0)[:, None], largest


def keys_of(r: np.ndarray) -> np.ndarray:
    """The int64 key of each row of quantised ratios."""
    q = np.clip((r / Q.BIN).astype(np.int64), 0, Q.NBINS - 1)
    return (q * (Q.NBINS ** np.arange(5))).sum(axis=1)


def image_patterns(vectors: np.ndarray, level_deg: float,
                   slack: float) -> tuple[np.ndarray, np.ndarray]:
    """Observed patterns (M x 4 rows) and their six edges, by the table builder's rule."""
    top = np.arange(min(len(vectors), IMAGE_STARS))
    size = math.radians(level_deg) * slack
    quads = Q.all_quads(vectors[top], Q.PATTERN_SIZE * size, Q.MAX_PATTERN_SIZE * size,
                        max_higher=IMAGE_STARS, k=IMAGE_NEAREST)
    return quads, edge_angles(vectors, quads)


def _query_keys(r: np.ndarray) -> np.ndarray:
    lo = np.clip(((r - RATIO_TOLERANCE) / Q.BIN).astype(np.int64), 0, Q.NBINS - 1)
    hi = np.clip(((r + RATIO_TOLERANCE) / Q.BIN).astype(np.int64), 0, Q.NBINS - 1)
    pick = np.array(list(itertools.product((0, 1), repeat=5)))  # 32 x 5
    q = np.where(pick[None, :, :] == 0, lo[:, None, :], hi[:, None, :])
    return (q * (Q.NBINS ** np.arange(5))).sum(axis=2)


def _lookup(table: Q.QuadLevel, keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For each query key, the table rows holding it: (query index, table row)."""
    lo = np.searchsorted(table.keys, keys, side="left")
    hi = np.searchsorted(table.keys, keys, side="right")
    counts = hi - lo
    query = np.repeat(np.arange(len(keys)), counts)
    offset = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    return query, np.repeat(lo, counts) + offset


def match_quads(quads: np.ndarray, edges: np.ndarray, table: Q.QuadLevel,
                cat_vectors: np.ndarray):
    """(obs rows, catalog rows in matching order, scale, error) of the image patterns
    ``quads`` with their ``edges``, best first."""
    empty = (np.zeros((0, 4), np.int64), np.zeros((0, 4), np.int64), np.zeros(0), np.zeros(0))
    if len(quads) == 0 or len(table) == 0:
        return empty
    r, largest = ratios(edges)
    qi, rows = _lookup(table, _query_keys(r).ravel())
    qi //= 32
    step = 0.5 / Q.RATIO_STEPS
    near = np.abs(table.ratios[rows] * (1.0 / Q.RATIO_STEPS) - r[qi]).max(axis=1)
    qi, rows = qi[near <= RATIO_TOLERANCE + step], rows[near <= RATIO_TOLERANCE + step]
    if len(qi) == 0:
        return empty
    pair = np.unique(qi * len(table) + rows)
    qi, rows = pair // len(table), pair % len(table)
    img = edges[qi] / largest[qi, None]
    cat_quads = table.quads[rows].astype(np.int64)
    cat_edges = edge_angles(cat_vectors, cat_quads)
    cat = cat_edges / cat_edges.max(axis=1, keepdims=True)
    err = np.abs(img[:, None, :] - cat[:, PERM_EDGES]).max(axis=2)
    best = np.argmin(err, axis=1)
    error = err[np.arange(len(qi)), best]
    good = np.flatnonzero(error <= RATIO_TOLERANCE)
    good = good[np.argsort(error[good], kind="stable")][:MAX_CANDIDATES]
    perm = PERMS[best[good]]
    cat_ordered = np.take_along_axis(cat_quads[good], perm, axis=1)
    scale = edges[qi[good]].sum(axis=1) / np.take_along_axis(
        cat_edges[good], PERM_EDGES[best[good]], axis=1).sum(axis=1)
    return quads[qi[good]], cat_ordered, scale, error[good]


def confirm_counts(x: np.ndarray, y: np.ndarray, camera, obs_q: np.ndarray,
                   cat_q: np.ndarray, f: np.ndarray, cat_v: np.ndarray) -> np.ndarray:
    """The batched numpy confirmation count that ``_core.matchers.quad_confirm`` replaced: SVD
    Wahba per candidate, a k-d tree's nearest catalog star of each projected bright star."""
    from scipy.spatial import cKDTree

    from startrack.attitude import wahba_matrices
    from startrack.matchers._quad import CHECK_RADIUS_PX, CHECK_STARS

    def pinhole(px, py, fs):
        v = np.stack([(px - camera.cx) / fs[:, None], (py - camera.cy) / fs[:, None],
                      np.ones_like(px)], axis=-1)
        return v / np.linalg.norm(v, axis=-1, keepdims=True)

    n = min(CHECK_STARS, len(x))
    matrices = wahba_matrices(pinhole(x[obs_q], y[obs_q], f), cat_v[cat_q])
    others = pinhole(np.broadcast_to(x[:n], (len(f), n)), np.broadcast_to(y[:n], (len(f), n)),
                     f)
    sky = np.einsum("pij,pkj->pki", matrices, others)
    radius = CHECK_RADIUS_PX / f
    _, rows = cKDTree(cat_v).query(sky.reshape(-1, 3),
                                   distance_upper_bound=2.0 * np.sin(radius.max() / 2.0))
    rows = rows.reshape(len(f), n)
    hit = rows < len(cat_v)
    cos = np.einsum("pkj,pkj->pk", sky, cat_v[np.where(hit, rows, 0)])
    hit &= cos >= np.cos(radius)[:, None]
    in_quad = (np.arange(n)[None, :, None] == obs_q[:, None, :]).any(axis=2)
    return np.count_nonzero(hit & ~in_quad, axis=1)
