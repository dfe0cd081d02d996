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
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np
from scipy.spatial.transform import Rotation

from startrack._core import shared
from startrack._core.verify.entry_points import (
    ACCEPTED,
    BAD_INDEX,
    NOT_ACCEPTED,
    UNLABELLED,
    binomial_tail,
)
from startrack.attitude import rotation_from_quat
from startrack.match_records import Hypothesis, Observation
from startrack.verify._frame import FrameVerifier

if TYPE_CHECKING:
    from startrack.database import StarDatabase


@dataclass(frozen=True)
class VerifyConfig:
    """``match_radius_px``: how far an observed star may lie from its catalog star (None:
    ``radius_sigma`` centroid sigmas, at least ``min_radius_px``). ``max_false_probability``:
    the bound on a coincidental match. ``min_confirmed``: stars outside the hypothesis that
    must be confirmed whatever the probability says. ``catalog_stars``: the bound counts
    only the brightest this many catalog stars in the image (0: all), for a check of a
    frame's brightest spots alone."""

    match_radius_px: float | None = None
    radius_sigma: float = 4.0
    min_radius_px: float = 1.0
    max_false_probability: float = 1e-9
    min_confirmed: int = 2
    max_hypotheses: int = 500
    catalog_stars: int = 0

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
    #: once accepted: each reported star's residual (arcsec, in the order of obs_index,
    #: which is then ascending) and the attitude's quaternion ``[x, y, z, w]``
    residual_arcsec: np.ndarray | None = None
    quaternion: np.ndarray | None = None
    #: once accepted: the observed stars' unit vectors the residuals were measured with
    #: (the checked frame's ``Observation.vectors``, the array itself)
    obs_vectors: np.ndarray | None = None
    #: not accepted though the bound passed: the final labelling kept too few stars to
    #: carry it (a camera off in scale); ``obs_index``, ``cat_index`` are then the
    #: refinement's matched pairs, to which a nominal camera may be refitted
    unlabelled: bool = False

    @classmethod
    def _of(cls, accepted: bool, matrix: np.ndarray, obs_index: np.ndarray,
            cat_index: np.ndarray, false_probability: float, confirmed: int,
            residual_arcsec: np.ndarray | None = None, quaternion: np.ndarray | None = None,
            obs_vectors: np.ndarray | None = None, unlabelled: bool = False,
            ) -> Verification:
        """The Verification of these fields, made without the frozen dataclass's
        ``__init__`` (one ``object.__setattr__`` per field: a tenth of a verification)."""
        made = object.__new__(cls)
        made.__dict__.update(accepted=accepted, matrix=matrix, obs_index=obs_index,
                             cat_index=cat_index, false_probability=false_probability,
                             confirmed=confirmed, residual_arcsec=residual_arcsec,
                             quaternion=quaternion, obs_vectors=obs_vectors,
                             unlabelled=unlabelled)
        return made

    @cached_property  # a scipy Rotation costs tens of microseconds to make
    def rotation(self) -> Rotation | None:
        if self.matrix is None:
            return None
        return rotation_of(self.matrix, self.quaternion)


def rotation_of(matrix: np.ndarray, quat: np.ndarray | None = None) -> Rotation:
    """The Rotation of ``matrix`` (camera to sky): ``Rotation.from_quat`` of its
    quaternion ``quat`` as the compiled core computes it
    (:func:`startrack._core.shared.matrix_to_quaternion`; computed when None)."""
    if quat is None:
        quat = shared.matrix_to_quaternion(np.ascontiguousarray(matrix, dtype=np.float64))
    return rotation_from_quat(quat)


def false_match_probability(n_other: int, n_confirmed: int, n_catalog_in_image: int,
                            radius_px: float, width: int, height: int) -> float:
    """Chance that ``n_confirmed`` or more of ``n_other`` stars land on a catalog star by
    coincidence under a wrong attitude (the compiled tail verification itself uses,
    :func:`startrack._core.verify.entry_points.binomial_tail`: scipy's ``bdtrc`` to 1e-12)."""
    if n_confirmed <= 0:
        return 1.0
    p = min(1.0, n_catalog_in_image * math.pi * radius_px**2 / (width * height))
    return float(binomial_tail(n_confirmed - 1, n_other, p))


def verify(hypothesis: Hypothesis, obs: Observation, database: StarDatabase,
           config: VerifyConfig, checker: FrameVerifier | None = None) -> Verification:
    """Solve the attitude from ``hypothesis`` and accept it only on independent evidence.

    One compiled call (:class:`startrack.verify._frame.FrameVerifier`): the first test,
    the bound, the refinement, the final labelling and the refit. ``checker`` is the
    frame's verifier when the caller holds one (one per frame serves every hypothesis;
    tracking's holds the catalog rows around its prediction).

    Raises
    ------
    IndexError
        A hypothesis index beyond the frame's stars or the catalog (numpy's rule; a
        negative one counts from the end).
    """
    obs_h = np.ascontiguousarray(hypothesis.obs_index, dtype=np.int64)
    cat_h = np.ascontiguousarray(hypothesis.cat_index, dtype=np.int64)
    checker = checker or FrameVerifier(obs, database, config)
    verdict = checker.check(obs_h, cat_h)
    if verdict.status == BAD_INDEX:
        wrapped = wrapped_hypothesis(obs_h, cat_h, len(obs), len(database.vectors))
        if wrapped is not None:
            verdict = checker.check(*wrapped)
    if verdict.status == ACCEPTED:
        return Verification._of(True, verdict.final, verdict.obs, verdict.rows,
                                verdict.probability, verdict.confirmed, verdict.residuals,
                                verdict.quaternion, checker.vectors)
    if verdict.status == NOT_ACCEPTED:
        return Verification._of(False, verdict.first, verdict.obs, verdict.rows,
                                verdict.probability, verdict.confirmed)
    if verdict.status == UNLABELLED:
        return Verification._of(False, verdict.final, verdict.obs, verdict.rows,
                                verdict.probability, verdict.confirmed, unlabelled=True)
    return _REJECTED


def wrapped_hypothesis(obs_h: np.ndarray, cat_h: np.ndarray, n_obs: int, n_cat: int,
                       ) -> tuple[np.ndarray, np.ndarray] | None:
    """A hypothesis the compiled check refused for its indices, read as numpy reads
    them (negative from the end): the indices to check again, or None when it does not
    pair three or more distinct stars with as many rows (refused as it is).

    Raises
    ------
    IndexError
        An index beyond the frame's stars or the catalog.
    """
    if not _distinct(obs_h, cat_h):
        return None
    return _wrapped(obs_h, n_obs), _wrapped(cat_h, n_cat)


def _distinct(obs_h: np.ndarray, cat_h: np.ndarray) -> bool:
    """Whether a hypothesis pairs three or more distinct stars with as many rows."""
    return (len(obs_h) == len(cat_h) >= 3 and len(set(obs_h.tolist())) == len(obs_h)
            and len(set(cat_h.tolist())) == len(cat_h))


def _wrapped(index: np.ndarray, size: int) -> np.ndarray:
    """``index`` as numpy reads it: negative from the end, IndexError beyond."""
    bad = index[(index < -size) | (index >= size)]
    if len(bad):
        raise IndexError(f"index {int(bad[0])} is out of bounds for axis 0 with size {size}")
    return np.where(index < 0, index + size, index)


_NONE = np.zeros(0, np.int64)  # empty, so sharing it across refusals is safe
_REJECTED = Verification(False, None, _NONE, _NONE, 1.0, 0)
