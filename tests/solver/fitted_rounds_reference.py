"""A nominal FOV's fit-and-verify rounds in Python, as startrack.solver._fov_fit ran them
before they were compiled (startrack._core.solver.fitted_rounds): kept as the reference that
tests/solver/test_fitted_rounds.py holds the compiled rounds to, bit for bit."""

from __future__ import annotations

import math

import numpy as np
from startrack._core.camera.fit import focal_error

from startrack.camera import Camera
from startrack.database import StarDatabase
from startrack.errors import InputError
from startrack.match_records import Hypothesis, Observation
from startrack.solver._fov_fit import (
    REFIT_ROUNDS,
    SETTLE_FRACTION,
    SETTLE_ROUNDS,
    fit_camera,
)
from startrack.verify import Verification, VerifyConfig, verify


def reference_rounds(hyp: Hypothesis, x: np.ndarray, y: np.ndarray, camera: Camera,
                     sigma_px: float, database: StarDatabase, config: VerifyConfig,
                     accepted: Verification | None = None,
                     ) -> tuple[Verification, Camera, Observation] | int:
    """Verify, fit the camera to the matched stars, verify again through the fitted
    camera, until a round matches the stars of the one before (or, past REFIT_ROUNDS,
    its fit moved the camera by at most SETTLE_FRACTION of the match radius):
    (verification, camera, observation), or the first verification's confirmed count (0
    after a failed fit, a later round, SETTLE_ROUNDS rounds that did not settle, or
    fitted stars that fix the focal length to no better than a match radius at the
    farthest corner: the compiled ``focal_error``, held to numpy in
    tests/camera/test_core_camera.py)."""
    cat, given = database.vectors, camera
    check = accepted or verify(hyp, Observation.from_pixels(x, y, camera, sigma_px),
                               database, config)
    confirmed = check.confirmed
    for round_ in range(SETTLE_ROUNDS):
        if not (check.accepted or check.unlabelled):  # unlabelled: its matches are fitted
            return confirmed
        before = camera
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
        if check.accepted and round_ >= REFIT_ROUNDS and _moved_px(
                given, before, camera) <= SETTLE_FRACTION * config.radius_px(obs):
            break  # past REFIT_ROUNDS: the fit moved the camera by a fraction of a radius
    else:
        return 0  # the rounds never settled: the last matches were never fitted
    if not check.accepted:
        return 0
    # the focal length the fitted stars fix must be good to a match radius at the corners
    spread = focal_error(camera.optics, x[last.obs_index], y[last.obs_index],
                         cat[last.cat_index])
    if not sigma_px * spread * camera.corner_radius_px <= config.radius_px(obs):
        return 0
    return check, camera, obs


def _moved_px(given: Camera, before: Camera, after: Camera) -> float:
    """How far a fit moved the camera at the farthest corner (px): the focal length's
    change in scale, and a k1's fitted to a pinhole ``given`` at that radius."""
    def fitted_k1(c: Camera) -> float:
        return c.distortion.k1 if given.distortion is None and c.distortion else 0.0

    r = after.corner_radius_px
    t = r / after.f_px
    return (r * abs(after.f_px / before.f_px - 1.0)
            + r * t * t * abs(fitted_k1(after) - fitted_k1(before)))


def _same_stars(a: Verification, b: Verification) -> bool:
    return (a.obs_index.shape == b.obs_index.shape and a.cat_index.shape == b.cat_index.shape
            and bool((a.obs_index == b.obs_index).all())
            and bool((a.cat_index == b.cat_index).all()))
