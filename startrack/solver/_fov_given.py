"""The nominal camera kept where the data do not reject it: a camera given exactly (a
simulated frame's sidecar, a calibrated camera file) is reported as given, not as a fitted
focal length and k1 a few parts in 1e4 off; where the nominal FOV was right, the answer
made through it stands without a refit (:func:`given_stands`, :func:`through_given`)."""

from __future__ import annotations

import math

import numpy as np

from startrack._core.camera.fit import SETTLED, fit_against, squared_residuals
from startrack.camera import Camera
from startrack.database import StarDatabase
from startrack.match_records import Hypothesis, Observation
from startrack.solver._calibrate_sigma import SIGNIFICANCE
from startrack.solver._fov_fit import (
    FIT_ITERATIONS,
    LENS_K1_CHI2,
    LENS_MAX_K1,
    LENS_MIN_R2,
    LENS_MIN_STARS,
)
from startrack.verify import Verification, VerifyConfig, verify

#: the given camera stands unless the fitted one lowers the matched stars' chi-square
#: by more than a 3-sigma chance would (the calibrate rule, startrack.solver._calibrate_sigma):
#: the two-sided normal tail, erfc(3 / sqrt(2))
GIVEN_REJECT_P = math.erfc(SIGNIFICANCE / math.sqrt(2.0))
#: the chi-square quantile of GIVEN_REJECT_P for the 1 or 2 parameters fitted (the focal
#: length, and k1), in closed form (not scipy.stats, whose import costs a few tenths of a
#: second in every identify process): one degree of freedom is a squared normal, so its
#: quantile is SIGNIFICANCE squared; two are an exponential of mean 2
_GIVEN_REJECT_CHI2 = {1: SIGNIFICANCE**2, 2: -2.0 * math.log(GIVEN_REJECT_P)}
#: stars of an accepted answer used as the hypothesis when its FOV is refitted or its
#: given camera verified again: the rest of the frame is the independent evidence
#: verification counts
REFIT_HYPOTHESIS_STARS = 4


def _given_kept(n_params: int, n_pairs: int, given_sq: float, fit_sq: float) -> bool:
    """Whether ``n_pairs`` matched stars do not reject the given camera for one fitted
    with ``n_params`` parameters (the focal length, and k1): the drop in their squared
    residuals (``given_sq`` to ``fit_sq``), over the noise the fitted residuals show,
    within the chi-square quantile of :data:`GIVEN_REJECT_P` for the parameters fitted.
    False when too few stars tell the cameras apart (or solve Wahba's problem)."""
    dof = n_pairs * 2 - 3 - n_params
    if dof <= 0 or not fit_sq > 0.0:
        return False
    return (given_sq - fit_sq) / (fit_sq / dof) <= _GIVEN_REJECT_CHI2[n_params]


def given_stands(given: Camera, x: np.ndarray, y: np.ndarray, obs_index: np.ndarray,
                 cat_vectors: np.ndarray) -> bool:
    """Whether an answer made through the ``given`` camera (its observed stars
    ``obs_index`` of pixels ``x``, ``y`` matched to ``cat_vectors``) stands as it is: the
    camera fitted to those pairs (:func:`fit_camera`'s fit) does not fit them
    significantly better (the rule of :func:`keep_given`), each camera at its own Wahba
    attitude of the pairs; False where the fit fails (a focal length not positive and
    finite, a lens folding back inside the image: the refit then says). A nominal FOV
    that was right then needs no refit and no second verification. The fit and both
    cameras' residuals are one compiled call
    (:func:`startrack._core.camera.fit.fit_against`)."""
    obs_index = np.ascontiguousarray(obs_index, dtype=np.int64)
    with_k1 = given.distortion is None and len(obs_index) >= LENS_MIN_STARS
    status, _, k1, given_sq, fit_sq = fit_against(
        given.optics, np.ascontiguousarray(x, dtype=np.float64),
        np.ascontiguousarray(y, dtype=np.float64), obs_index,
        np.ascontiguousarray(cat_vectors, dtype=np.float64), FIT_ITERATIONS, with_k1,
        LENS_MIN_R2, LENS_MAX_K1, LENS_K1_CHI2)
    if status != SETTLED:
        return False
    return _given_kept(1 + int(k1 != 0.0), len(obs_index), given_sq, fit_sq)


def keep_given(found: tuple[Verification, Camera, Observation], given: Camera,
               sigma_px: float, database: StarDatabase, config: VerifyConfig,
               ) -> tuple[Verification, Camera, Observation]:
    """``found`` (from :func:`verify_fitted`) with the ``given`` camera put back when the
    data do not reject it: a camera given exactly (a simulated frame's sidecar) is reported
    as given, not as a fitted focal length and k1 a few parts in 1e4 off. Rejected means
    the fit's drop in the squared residuals of the matched stars, over the noise the
    fitted residuals show, exceeds the chi-square quantile of :data:`GIVEN_REJECT_P` for
    the parameters fitted; the given camera must also pass verification again, with the
    :data:`REFIT_HYPOTHESIS_STARS` brightest matched stars as the hypothesis (the rest of
    the frame is the independent evidence, as when a FOV is refitted)."""
    check, fitted, obs = found
    if fitted == given:
        return found
    x, y = np.ascontiguousarray(obs.x), np.ascontiguousarray(obs.y)
    obs_index = np.ascontiguousarray(check.obs_index, dtype=np.int64)
    rows = np.ascontiguousarray(check.cat_index, dtype=np.int64)
    vectors = np.ascontiguousarray(database.vectors, dtype=np.float64)

    def squared(camera: Camera) -> float:
        # the matched stars through ``camera`` at their own Wahba attitude, one call
        return squared_residuals(camera.optics, x, y, obs_index, rows, vectors)

    # the fitted camera's residuals are its verification's own when it checked ``obs``:
    # the same Wahba fit of the same pairs (its final attitude), the same angles
    fit_sq = float(np.sum(check.residual_arcsec ** 2)) if check.obs_vectors is obs.vectors \
        else squared(fitted)
    n_params = 1 + int(fitted.distortion != given.distortion)
    if not _given_kept(n_params, len(check.obs_index), squared(given), fit_sq):
        return found
    given_obs = Observation.from_pixels(obs.x, obs.y, given, sigma_px, obs.flux)
    first = np.argsort(check.obs_index)[:REFIT_HYPOTHESIS_STARS]
    hyp = Hypothesis(check.obs_index[first], check.cat_index[first])
    again = verify(hyp, given_obs, database, config)
    return (again, given, given_obs) if again.accepted else found


def through_given(hyp: Hypothesis, x, y, given: Camera, sigma_px: float,
                   database: StarDatabase, config: VerifyConfig, flux=None):
    """``hyp`` verified through the nominal camera ``given``: (verification, camera, obs)
    when accepted and the camera fitted to its stars does not fit them
    significantly better (:func:`given_stands`); else None. A nominal FOV that is right
    then costs one verification, not the fit-and-verify rounds and a second check of the
    nominal camera (:func:`keep_given`). ``flux``: the stars' measured fluxes, if any."""
    obs = Observation.from_pixels(x, y, given, sigma_px, flux)
    check = verify(hyp, obs, database, config)
    if not check.accepted or not given_stands(
            given, x, y, check.obs_index, database.vectors[check.cat_index]):
        return None
    return check, given, obs
