"""Planar-triangle features of observed star triples (Cole and Crassidis, 2006), with the
sigmas propagated from the centroid noise: shared by the triangle and hybrid matchers."""

from __future__ import annotations

import numpy as np

from startrack.database.triangles import feature_sigmas, triangle_features
from startrack.types import Observation


def feature_sigma(obs: Observation, tolerance_sigma: float, min_tolerance_rad: float) -> float:
    """Per-axis centroid sigma used for triangle features, floored like angle windows."""
    floor = min_tolerance_rad / (tolerance_sigma * np.sqrt(2.0))
    return max(obs.sigma_rad, floor)


def feature_table(vectors: np.ndarray, triples: np.ndarray, sigma: float) -> np.ndarray:
    """(area, polar, sigma_area, sigma_polar) of every observed triple (rows of
    ``triples``, T x 3), in one batch: a (T x 4) array."""
    idx = np.asarray(triples, dtype=np.int64).reshape(-1, 3)
    verts = [vectors[idx[:, m]] for m in range(3)]
    return np.column_stack([*triangle_features(*verts), *feature_sigmas(*verts, sigma)])


def observed_features(vectors: np.ndarray, triples: list[tuple[int, int, int]],
                      sigma: float) -> dict[tuple[int, int, int], tuple[float, ...]]:
    """:func:`feature_table` as a dict by triple."""
    feats = feature_table(vectors, np.array(triples, dtype=np.int64), sigma)
    return dict(zip(triples, map(tuple, feats.tolist()), strict=True))
