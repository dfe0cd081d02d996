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
from functools import lru_cache

import numpy as np
from scipy.spatial.transform import Rotation
from scipy.special import bdtrc

from startrack.attitude import wahba_matrices
from startrack.camera import Camera
from startrack.database import StarDatabase
from startrack.labelling import label_stars
from startrack.matching.verify_kernels import nearest_matches
from startrack.types import Hypothesis, Observation

MAX_REFINEMENTS = 5
# The catalog cone around a boresight: 2% beyond the farthest image corner, so that a star
# just outside the frame edge whose match radius reaches into the image is still projected.
CONE_MARGIN = 1.02
# A cached cone is reused while the boresight moves less than this fraction of its radius
# (refinement moves it by arcseconds) ...
CONE_REUSE_FRACTION = 0.01
# ... and is looked up this much wider, so that such a move keeps every image star in it.
CONE_LOOKUP_MARGIN = 1.01
CAPTURE = 3.0  # the wider capture of a refinement, in match radii (see _refine)


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
    obs_index: np.ndarray  # matched stars; once accepted, the reported identities
    cat_index: np.ndarray
    false_probability: float
    confirmed: int  # matched stars outside the hypothesis


@lru_cache(maxsize=64)
def _cone_radius(camera: Camera) -> float:
    return math.radians(camera.half_diagonal_deg) * CONE_MARGIN


class _Projector:
    """The catalog stars around one attitude, projected into the image.

    The cone of candidate stars is looked up once and reused while the boresight stays
    well inside its margin: refining an accepted attitude moves it by arcseconds, and the
    image test after the projection decides which stars are in, so the answer is the same
    as with a fresh cone.
    """

    def __init__(self, obs: Observation, database: StarDatabase, radius_px: float) -> None:
        self.obs, self.database, self.radius_px = obs, database, radius_px
        self.cone_rad = _cone_radius(obs.camera)
        self.margin_cos = math.cos(CONE_REUSE_FRACTION * self.cone_rad)
        self.boresight = np.zeros(3)
        self.rows = np.zeros(0, np.int64)
        self.vectors = np.zeros((0, 3))

    def __call__(self, matrix: np.ndarray,
                 radius_px: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Rows and pixel positions of the catalog stars that fall in the image."""
        cam = self.obs.camera
        boresight = matrix[:, 2]
        if float(boresight @ self.boresight) < self.margin_cos:
            self.rows = self.database.cone(boresight, self.cone_rad * CONE_LOOKUP_MARGIN)
            self.vectors = self.database.vectors[self.rows]
            self.boresight = boresight
        if len(self.rows) == 0:
            return self.rows, np.zeros(0), np.zeros(0)
        x, y, front = cam.vector_to_pixel(self.vectors @ matrix)  # R^T v for each row
        keep = front & cam.in_image(x, y, margin=-radius_px)
        return self.rows[keep], x[keep], y[keep]

    def match(self, matrix: np.ndarray,
              radius_px: float | None = None) -> tuple[np.ndarray, np.ndarray, int]:
        """Observed stars paired with the projected catalog stars within ``radius_px``
        at the attitude ``matrix`` (camera to sky), each catalog star at most once (nearest
        wins): (obs_index, cat_index, n_catalog_in_image)."""
        radius_px = self.radius_px if radius_px is None else radius_px
        rows, cx, cy = self(matrix, radius_px)
        obs = self.obs
        if len(rows) == 0 or len(obs) == 0:
            return np.zeros(0, np.int64), np.zeros(0, np.int64), len(rows)
        # Tens of stars on each side: a direct distance table (compiled) beats a k-d tree.
        obs_idx, cat_pos = nearest_matches(obs.x, obs.y, cx, cy, float(radius_px))
        return obs_idx, rows[cat_pos], len(rows)


def false_match_probability(n_other: int, n_confirmed: int, n_catalog_in_image: int,
                            radius_px: float, width: int, height: int) -> float:
    """Chance that ``n_confirmed`` or more of ``n_other`` stars land on a catalog star by
    coincidence under a wrong attitude."""
    if n_confirmed <= 0:
        return 1.0
    p = min(1.0, n_catalog_in_image * math.pi * radius_px**2 / (width * height))
    return float(bdtrc(n_confirmed - 1, n_other, p))  # binom.sf without its overhead


def verify(hypothesis: Hypothesis, obs: Observation, database: StarDatabase,
           config: VerifyConfig, project: _Projector | None = None) -> Verification:
    """Solve the attitude from ``hypothesis`` and accept it only on independent evidence.

    ``project`` replaces the default catalog projector with one of the same interface
    (``match`` and calling it): tracking passes one restricted to the stars around its
    prediction, so that a tracked frame is held to exactly this test and labelling."""
    rejected = Verification(False, None, np.zeros(0, np.int64), np.zeros(0, np.int64), 1.0, 0)
    obs_h = np.asarray(hypothesis.obs_index, dtype=np.int64)
    cat_h = np.asarray(hypothesis.cat_index, dtype=np.int64)
    if len(obs_h) < 3 or len(np.unique(cat_h)) != len(cat_h) or len(np.unique(obs_h)) != len(obs_h):
        return rejected
    radius_px = config.radius_px(obs)
    radius_rad = radius_px / obs.camera.f_px
    cam_h, cat_v = obs.vectors[obs_h], database.vectors[cat_h]
    matrix = wahba_matrices(cam_h, cat_v)
    cos_err = np.einsum("ij,ij->i", cam_h @ matrix.T, cat_v)
    if np.any(cos_err < math.cos(radius_rad)):
        return rejected
    project = project or _Projector(obs, database, radius_px)
    obs_m, cat_m, n_cat = project.match(matrix)
    # Evidence comes only from stars the matcher did not choose.
    chosen = np.zeros(len(obs), bool)
    chosen[obs_h] = True
    confirmed = int(np.count_nonzero(~chosen[obs_m]))
    n_other = len(obs) - len(obs_h)
    prob = false_match_probability(n_other, confirmed, n_cat, radius_px,
                                   obs.camera.width, obs.camera.height)
    accepted = confirmed >= config.min_confirmed and prob <= config.max_false_probability
    if not accepted:
        return Verification(False, Rotation.from_matrix(matrix), obs_m, cat_m, prob, confirmed)
    obs_m, cat_m, matrix = _final_labels(project, _refine(project, obs_m, cat_m)[2])
    return Verification(True, Rotation.from_matrix(matrix), obs_m, cat_m, prob, confirmed)


def _final_labels(project: _Projector,
                  matrix: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The identities to report at the accepted attitude (startrack.labelling: one-to-one,
    ambiguous stars left unidentified), and the attitude refitted to them."""
    rows, cx, cy = project(matrix, project.radius_px)
    mag = project.database.catalog.mag[rows]
    labels = label_stars(project.obs, rows, cx, cy, mag, project.radius_px)
    if len(labels.obs_index) < 3:  # the attitude stands on verification's evidence
        return labels.obs_index, labels.cat_index, matrix
    vectors, cat = project.obs.vectors, project.database.vectors
    return (labels.obs_index, labels.cat_index,
            wahba_matrices(vectors[labels.obs_index], cat[labels.cat_index]))


def _refine(project: _Projector, obs_m: np.ndarray,
            cat_m: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Refit on every matched star and match again until the matched set stops changing
    (it may grow, or keep its size with other pairs; it never shrinks): a compact
    hypothesis leaves stars far from it unmatched at first, and a pair matched under the
    first attitude can belong to a neighbour under the refined one.

    When a plain refit changes nothing, the matches within ``CAPTURE`` match radii are
    refitted once, kept only if they then match more stars at the match radius: a
    hypothesis with one star a few pixels off, far from the others, can still pass (the
    stars near the others confirm it) with the attitude turned so that the rest of the
    frame lies beyond the match radius, where a plain refit never sees it.

    Returns the matches and the attitude fitted to them."""
    vectors, cat = project.obs.vectors, project.database.vectors
    matrix = wahba_matrices(vectors[obs_m], cat[cat_m])
    for _ in range(MAX_REFINEMENTS):
        obs_new, cat_new, _ = project.match(matrix)
        changed = len(obs_new) > len(obs_m) or (
            len(obs_new) == len(obs_m)
            and not (np.array_equal(obs_new, obs_m) and np.array_equal(cat_new, cat_m)))
        if not changed:
            obs_w, cat_w, _ = project.match(matrix, CAPTURE * project.radius_px)
            obs_new, cat_new, _ = project.match(wahba_matrices(vectors[obs_w], cat[cat_w]))
            if len(obs_new) <= len(obs_m):
                break
        obs_m, cat_m = obs_new, cat_new
        matrix = wahba_matrices(vectors[obs_m], cat[cat_m])
    return obs_m, cat_m, matrix
