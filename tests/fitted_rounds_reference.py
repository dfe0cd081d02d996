"""A nominal FOV's fit-and-verify rounds in Python, as startrack.solver._fov_fit ran them
before they were compiled (startrack._core.fitted_rounds): kept as the reference that
tests/test_fitted_rounds.py holds the compiled rounds to, bit for bit."""

from __future__ import annotations

import math

import numpy as np

from startrack.camera._model import Camera
from startrack.database import StarDatabase
from startrack.errors import InputError
from startrack.solver._fov_fit import REFIT_ROUNDS, fit_camera
from startrack.types import Hypothesis, Observation
from startrack.verify._verification import Verification, VerifyConfig, verify


def reference_rounds(hyp: Hypothesis, x: np.ndarray, y: np.ndarray, camera: Camera,
                     sigma_px: float, database: StarDatabase, config: VerifyConfig,
                     accepted: Verification | None = None,
                     ) -> tuple[Verification, Camera, Observation] | int:
    """Verify, fit the camera to the matched stars, verify again through the fitted
    camera, until a round matches the stars of the one before: (verification, camera,
    observation), or the first verification's confirmed count (0 after a failed fit or
    a later round)."""
    cat = database.vectors
    check = accepted or verify(hyp, Observation.from_pixels(x, y, camera, sigma_px),
                               database, config)
    confirmed = check.confirmed
    for _ in range(REFIT_ROUNDS):
        if not (check.accepted or check.unlabelled):  # unlabelled: its matches are fitted
            return confirmed
        try:
            camera = fit_camera(camera, x[check.obs_index], y[check.obs_index],
                                cat[check.cat_index])
        except InputError:  # a fitted lens that folds back inside the image
            return 0
        if not (camera.f_px > 0 and math.isfinite(camera.f_px)):
            return 0
        obs = Observation.from_pixels(x, y, camera, sigma_px)
        last, check = check, verify(hyp, obs, database, config)
        if check.accepted and _same_stars(last, check):
            break
    return (check, camera, obs) if check.accepted else 0


def _same_stars(a: Verification, b: Verification) -> bool:
    return (a.obs_index.shape == b.obs_index.shape and a.cat_index.shape == b.cat_index.shape
            and bool((a.obs_index == b.obs_index).all())
            and bool((a.cat_index == b.cat_index).all()))
