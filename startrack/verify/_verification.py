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

import functools
import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from startrack.database import StarDatabase
from startrack.matching import check_kernels as check
from startrack.matching import verify_kernels as kern
from startrack.matching.projector import CatalogProjector
from startrack.types import Hypothesis, Observation
from startrack.verify._labelling import kernel_params, label_stars


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
    matrix: np.ndarray | None  # the attitude, camera to sky
    obs_index: np.ndarray  # matched stars; once accepted, the reported identities
    cat_index: np.ndarray
    false_probability: float
    confirmed: int  # matched stars outside the hypothesis
    #: once accepted by the one-call path: each reported star's residual (arcsec, in the
    #: order of obs_index, which is then ascending) and the attitude's quaternion
    residual_arcsec: np.ndarray | None = None
    quaternion: np.ndarray | None = None

    @property
    def rotation(self) -> Rotation | None:
        if self.matrix is None:
            return None
        return rotation_of(self.matrix, self.quaternion)


def rotation_of(matrix: np.ndarray, quat: np.ndarray | None = None) -> Rotation:
    """``Rotation.from_quat(matrix_to_quaternion(matrix))``, the same numbers built through
    the pickling protocol from ``quat`` (default: computed), the quaternion normalised as
    from_quat normalises it (:func:`startrack.matching.check_kernels.scipy_quaternion`):
    from_quat's input checks cost as much as the rest of a solved frame's Python."""
    if not _state_matches():
        return Rotation.from_quat(kern.matrix_to_quaternion(matrix))
    rotation = Rotation.__new__(Rotation)
    quat = check.scipy_quaternion(matrix) if quat is None else quat
    rotation.__setstate__((np.reshape(quat, (1, 4)), True))
    return rotation


@functools.cache
def _state_matches() -> bool:
    """Whether this scipy's pickled state builds the Rotation from_quat does."""
    matrix = kern.wahba(np.eye(3), np.array([[0.0, 0.6, 0.8], [1.0, 0.0, 0.0],
                                             [0.0, 0.8, -0.6]]))
    try:
        rotation = Rotation.__new__(Rotation)
        rotation.__setstate__((check.scipy_quaternion(matrix).reshape(1, 4), True))
        ref = Rotation.from_quat(kern.matrix_to_quaternion(matrix))
        return bool(rotation.single and np.array_equal(rotation.as_quat(canonical=False),
                                                       ref.as_quat(canonical=False))
                    and np.array_equal(rotation.as_matrix(), ref.as_matrix()))
    except (AttributeError, TypeError, ValueError):
        return False


def false_match_probability(n_other: int, n_confirmed: int, n_catalog_in_image: int,
                            radius_px: float, width: int, height: int) -> float:
    """Chance that ``n_confirmed`` or more of ``n_other`` stars land on a catalog star by
    coincidence under a wrong attitude (the compiled tail every verification path uses,
    :func:`startrack.matching.check_kernels.binomial_tail`: scipy's ``bdtrc`` to 1e-12)."""
    if n_confirmed <= 0:
        return 1.0
    p = min(1.0, n_catalog_in_image * math.pi * radius_px**2 / (width * height))
    return float(check.binomial_tail(n_confirmed - 1, n_other, p))


def verify(hypothesis: Hypothesis, obs: Observation, database: StarDatabase,
           config: VerifyConfig, project: CatalogProjector | None = None) -> Verification:
    """Solve the attitude from ``hypothesis`` and accept it only on independent evidence.

    ``project`` replaces the default projector (the catalog cone around each attitude)
    with one of the same class over other rows: tracking passes one restricted to the
    stars around its prediction, so that a tracked frame is held to exactly this test
    and labelling."""
    obs_h = np.ascontiguousarray(hypothesis.obs_index, dtype=np.int64)
    cat_h = np.ascontiguousarray(hypothesis.cat_index, dtype=np.int64)
    project = project or CatalogProjector(obs, database, config.radius_px(obs))
    # Evidence comes only from stars the matcher did not choose (``confirmed``).
    status, matrix, obs_m, cat_m, prob, confirmed, final, resid, quat = project.check(
        obs_h, cat_h, config, kernel_params)
    if status == check.ACCEPTED:
        return Verification(True, final, obs_m, cat_m, prob, confirmed, resid, quat)
    if status == check.NOT_ACCEPTED:
        return Verification(False, matrix, obs_m, cat_m, prob, confirmed)
    if status == check.BEYOND_CONE:  # refined beyond the cone: step by step on a fresh one
        obs_m, cat_m, final = _final_labels(project, project.refine(obs_m, cat_m)[2])
        return Verification(True, final, obs_m, cat_m, prob, confirmed)
    if status == check.REJECTED:
        return _rejected()
    return _verify_steps(obs_h, cat_h, obs, database, config, project)


def _verify_steps(obs_h: np.ndarray, cat_h: np.ndarray, obs: Observation,
                  database: StarDatabase, config: VerifyConfig,
                  project: CatalogProjector) -> Verification:
    """:func:`verify` step by step, for a hypothesis the one-call path refuses to index
    (repeated or out-of-range stars, unequal lengths): numpy's indexing decides."""
    if len(obs_h) < 3 or len(set(cat_h.tolist())) != len(cat_h) \
            or len(set(obs_h.tolist())) != len(obs_h):
        return _rejected()
    radius_px = config.radius_px(obs)
    matrix, obs_m, cat_m, n_cat, confirmed = project.first_match(
        obs_h, database.vectors[cat_h], math.cos(radius_px / obs.camera.f_px))
    if matrix is None:
        return _rejected()
    n_other = len(obs) - len(obs_h)
    prob = false_match_probability(n_other, confirmed, n_cat, radius_px,
                                   obs.camera.width, obs.camera.height)
    accepted = confirmed >= config.min_confirmed and prob <= config.max_false_probability
    if not accepted:
        return Verification(False, matrix, obs_m, cat_m, prob, confirmed)
    labelled = project.accept(obs_m, cat_m, kernel_params(obs, radius_px))
    if labelled is None:  # refined beyond the cone: step by step on a fresh one
        labelled = _final_labels(project, project.refine(obs_m, cat_m)[2])
    obs_m, cat_m, matrix = labelled
    return Verification(True, matrix, obs_m, cat_m, prob, confirmed)


def _rejected() -> Verification:
    return _REJECTED


_NONE = np.zeros(0, np.int64)  # empty, so sharing it across refusals is safe
_REJECTED = Verification(False, None, _NONE, _NONE, 1.0, 0)


def _final_labels(project: CatalogProjector,
                  matrix: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The identities to report at the accepted attitude (startrack.verify._labelling: one-to-one,
    ambiguous stars left unidentified), and the attitude refitted to them."""
    rows, cx, cy = project(matrix, project.radius_px)
    mag = project.database.catalog.mag[rows]
    labels = label_stars(project.obs, rows, cx, cy, mag, project.radius_px)
    if len(labels.obs_index) < 3:  # the attitude stands on verification's evidence
        return labels.obs_index, labels.cat_index, matrix
    return (labels.obs_index, labels.cat_index,
            kern.wahba(project.obs_vectors[labels.obs_index],
                       project.database.vectors[labels.cat_index]))
