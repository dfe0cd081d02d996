"""Planar-triangle features of observed star triples (Cole and Crassidis, 2006), with the
sigmas propagated from the centroid noise: shared by the triangle and hybrid matchers."""

from __future__ import annotations

import numpy as np

from startrack.database import feature_sigmas, triangle_features
from startrack.match_records import Observation


def feature_sigma(obs: Observation, tolerance_sigma: float, min_tolerance_rad: float) -> float:
    """Per-axis centroid sigma used for triangle features, floored like angle windows."""
    floor = min_tolerance_rad / (tolerance_sigma * np.sqrt(2.0))
    return max(obs.sigma_rad, floor)


def observed_features(vectors: np.ndarray, triples: list[tuple[int, int, int]],
                      sigma: float) -> dict[tuple[int, int, int], tuple[float, ...]]:
    """(area, polar, sigma_area, sigma_polar) of every observed triple, in one batch."""
    idx = np.array(triples, dtype=np.int64).reshape(-1, 3)
    verts = [vectors[idx[:, m]] for m in range(3)]
    feats = np.column_stack([*triangle_features(*verts), *feature_sigmas(*verts, sigma)])
    return dict(zip(triples, map(tuple, feats.tolist()), strict=True))

__all__ = [
    "feature_sigma", "observed_features",
]
