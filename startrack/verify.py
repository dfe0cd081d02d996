"""Verification shared by every matcher: accept a hypothesis only on independent evidence.

From a hypothesis (observed star k is catalog row c_k) the attitude follows by Wahba's
problem; the catalog is then projected into the frame and every other observed star is
checked for a catalog star within the match radius. A wrong attitude puts catalog stars
at random places, so each other observed star lands on one by chance with probability
``p = n_catalog_in_image * pi * r^2 / image_area``. The hypothesis is accepted only when
the number of confirmed stars outside the hypothesis would arise by chance with
probability below ``max_false_probability`` (binomial tail, as tetra3 argues).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation
from scipy.stats import binom

from startrack.attitude import solve_wahba
from startrack.database import StarDatabase
from startrack.matchers.base import Hypothesis, Observation

MAX_REFINEMENTS = 5


@dataclass(frozen=True)
class VerifyConfig:
    """``match_radius_px``: how far an observed star may lie from its catalog star (None:
    ``radius_sigma`` centroid sigmas, at least ``min_radius_px``). ``max_false_probability``:
    the bound on a coincidental match. ``min_confirmed``: stars outside the hypothesis that
    must be confirmed whatever the probability says."""

    match_radius_px: float | None = None
    radius_sigma: float = 4.0
    min_radius_px: float = 1.0
    max_false_probability: float = 1e-9
    min_confirmed: int = 2
    max_hypotheses: int = 500

    def radius_px(self, obs: Observation) -> float:
        if self.match_radius_px is not None:
            return float(self.match_radius_px)
        sigma_px = obs.sigma_rad * obs.camera.f_px
        return max(self.radius_sigma * sigma_px, self.min_radius_px)


@dataclass(frozen=True)
class Verification:
    """The outcome of checking one hypothesis against the whole frame."""

    accepted: bool
    rotation: Rotation | None
    obs_index: np.ndarray  # every observed star matched to the catalog
    cat_index: np.ndarray
    false_probability: float
    confirmed: int  # matched stars outside the hypothesis


def _project_catalog(rotation: Rotation, obs: Observation, database: StarDatabase,
                     radius_px: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rows and pixel positions of the catalog stars that fall in the image."""
    cam = obs.camera
    boresight = rotation.apply([0.0, 0.0, 1.0])
    rows = database.cone(boresight, math.radians(cam.half_diagonal_deg) * 1.02)
    if len(rows) == 0:
        return rows, np.zeros(0), np.zeros(0)
    x, y, front = cam.vector_to_pixel(rotation.inv().apply(database.vectors[rows]))
    keep = front & cam.in_image(x, y, margin=-radius_px)
    return rows[keep], x[keep], y[keep]


def match_catalog(rotation: Rotation, obs: Observation, database: StarDatabase,
                  radius_px: float) -> tuple[np.ndarray, np.ndarray, int]:
    """Pair observed stars with projected catalog stars within ``radius_px``, each catalog
    star at most once (nearest wins). Returns (obs_index, cat_index, n_catalog_in_image)."""
    rows, cx, cy = _project_catalog(rotation, obs, database, radius_px)
    if len(rows) == 0 or len(obs) == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), len(rows)
    dist, nearest = cKDTree(np.column_stack([cx, cy])).query(
        np.column_stack([obs.x, obs.y]), distance_upper_bound=radius_px)
    hit = np.isfinite(dist)
    obs_idx = np.flatnonzero(hit)
    cat_pos = nearest[hit]
    order = np.argsort(dist[hit], kind="stable")
    _, first = np.unique(cat_pos[order], return_index=True)
    chosen = np.sort(order[first])
    return obs_idx[chosen], rows[cat_pos[chosen]], len(rows)


def false_match_probability(n_other: int, n_confirmed: int, n_catalog_in_image: int,
                            radius_px: float, width: int, height: int) -> float:
    """Chance that ``n_confirmed`` or more of ``n_other`` stars land on a catalog star by
    coincidence under a wrong attitude."""
    if n_confirmed <= 0:
        return 1.0
    p = min(1.0, n_catalog_in_image * math.pi * radius_px**2 / (width * height))
    return float(binom.sf(n_confirmed - 1, n_other, p))


def verify(hypothesis: Hypothesis, obs: Observation, database: StarDatabase,
           config: VerifyConfig) -> Verification:
    """Solve the attitude from ``hypothesis`` and accept it only on independent evidence."""
    rejected = Verification(False, None, np.zeros(0, np.int64), np.zeros(0, np.int64), 1.0, 0)
    obs_h = np.asarray(hypothesis.obs_index, dtype=np.int64)
    cat_h = np.asarray(hypothesis.cat_index, dtype=np.int64)
    if len(obs_h) < 3 or len(np.unique(cat_h)) != len(cat_h) or len(np.unique(obs_h)) != len(obs_h):
        return rejected
    radius_px = config.radius_px(obs)
    radius_rad = radius_px / obs.camera.f_px
    rotation = solve_wahba(obs.vectors[obs_h], database.vectors[cat_h])
    predicted = rotation.apply(obs.vectors[obs_h])
    cos_err = np.einsum("ij,ij->i", predicted, database.vectors[cat_h])
    if np.any(cos_err < math.cos(radius_rad)):
        return rejected
    obs_m, cat_m, n_cat = match_catalog(rotation, obs, database, radius_px)
    # Evidence comes only from stars the matcher did not choose.
    outside = ~np.isin(obs_m, obs_h)
    confirmed = int(outside.sum())
    n_other = len(obs) - len(obs_h)
    prob = false_match_probability(n_other, confirmed, n_cat, radius_px,
                                   obs.camera.width, obs.camera.height)
    accepted = confirmed >= config.min_confirmed and prob <= config.max_false_probability
    if not accepted:
        return Verification(False, rotation, obs_m, cat_m, prob, confirmed)
    # Refine on every matched star and match again until the matched set stops growing:
    # a compact hypothesis leaves stars far from it unmatched at first.
    for _ in range(MAX_REFINEMENTS):
        rotation = solve_wahba(obs.vectors[obs_m], database.vectors[cat_m])
        obs_new, cat_new, _ = match_catalog(rotation, obs, database, radius_px)
        if len(obs_new) <= len(obs_m):
            break
        obs_m, cat_m = obs_new, cat_new
    return Verification(True, rotation, obs_m, cat_m, prob, confirmed)
