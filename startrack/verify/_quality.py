"""How good a solution is: residuals, the attitude's 1-sigma from the fit, the catalog used.

The attitude of a solved frame is the least-squares (Wahba) rotation taking the
identified stars' camera-frame directions ``b_i`` onto their catalog directions. With
each direction off by independent isotropic noise of ``sigma`` radians per axis, the
small rotation error ``d`` (camera axes) of that fit has covariance
``sigma^2 (sum_i (I - b_i b_i^T))^-1`` (Shuster's QUEST covariance). ``sigma`` is
estimated from the fit's own residuals, ``sum r_i^2 / (2N - 3)`` (2 coordinates per star,
3 attitude parameters); ``rms_px`` is ``rms_arcsec`` at the plate scale of the principal
point. The boresight (camera z) moves by ``(d_x, d_y)``, the roll is
``d_z``; :data:`QUALITY_KEYS` are the record's keys (docs/conventions.md).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from startrack.match_records import Observation, Solution
from startrack.sky import Catalog

ARCSEC_PER_RAD = 180.0 / math.pi * 3600.0


@dataclass(frozen=True)
class Quality:
    """The ``quality`` of a solved record (docs/conventions.md)."""

    rms_arcsec: float
    max_arcsec: float
    rms_px: float
    sigma_boresight_arcsec: float | None
    sigma_roll_arcsec: float | None
    false_match_probability: float | None
    n_matched: int
    catalog: dict

    def to_dict(self) -> dict:
        return asdict(self)


QUALITY_KEYS = tuple(Quality.__dataclass_fields__)


def attitude_sigma_rad(cam_vectors: np.ndarray, noise_rad: float) -> tuple[float, float]:
    """1-sigma (boresight, roll) in radians of the Wahba fit to unit vectors
    ``cam_vectors`` (N x 3, camera frame) each with ``noise_rad`` per-axis noise."""
    b = np.asarray(cam_vectors, dtype=np.float64)
    info = len(b) * np.eye(3) - b.T @ b  # sum of (I - b b^T)
    try:
        cov = noise_rad ** 2 * np.linalg.inv(info)
    except np.linalg.LinAlgError:
        return math.inf, math.inf
    return math.sqrt(max(cov[0, 0] + cov[1, 1], 0.0)), math.sqrt(max(cov[2, 2], 0.0))


def catalog_depth(catalog: Catalog) -> dict:
    """The catalog a solution was matched against: its kind and faintest magnitude."""
    limit = catalog.source.get("mag_limit")
    if limit is None and len(catalog):
        limit = float(np.max(catalog.mag))
    return {"kind": catalog.source.get("kind"), "mag_limit": limit}


def solution_quality(solution: Solution, obs: Observation, catalog: Catalog) -> Quality | None:
    """The quality of a solved frame; None when it is not solved."""
    if not solution.solved or solution.rotation is None or len(solution.obs_index) == 0:
        return None
    res = np.asarray(solution.residual_arcsec, dtype=np.float64)
    n = len(res)
    rms = math.sqrt(float(np.mean(res ** 2)))
    # At the principal point's plate scale: the residuals are measured against catalog
    # directions that an aberration correction has moved, which pixels do not show.
    rms_px = rms / ARCSEC_PER_RAD * obs.camera.f_px
    k = solution.obs_index
    sigma_b = sigma_r = None
    if 2 * n > 3:
        noise = math.sqrt(float(np.sum(res ** 2)) / (2 * n - 3)) / ARCSEC_PER_RAD
        b, r = attitude_sigma_rad(obs.vectors[k], noise)
        sigma_b, sigma_r = _finite(b * ARCSEC_PER_RAD), _finite(r * ARCSEC_PER_RAD)
    return Quality(rms_arcsec=rms, max_arcsec=float(np.max(res)), rms_px=rms_px,
                   sigma_boresight_arcsec=sigma_b, sigma_roll_arcsec=sigma_r,
                   false_match_probability=_finite(solution.false_probability),
                   n_matched=n, catalog=catalog_depth(catalog))


def _finite(value: float) -> float | None:
    return float(value) if math.isfinite(value) else None
