"""The camera fitted to identified stars: the focal length and, for a lens nobody described,
its radial k1; and a hypothesis verified through the fitted camera (the fit and the check
behind every answer of :mod:`startrack.solver._fov_search`)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from startrack._core.camera.fit import BAD_FOCAL
from startrack._core.camera.fit import fit_focal as fit_focal_kernel
from startrack._core.solver.fitted_rounds import FittedRounds
from startrack.camera import Camera, RadialDistortion
from startrack.database import StarDatabase
from startrack.match_records import Hypothesis, Observation
from startrack.solver._calibrate_sigma import SIGNIFICANCE
from startrack.verify import (
    CAPTURE,
    CONE_LOOKUP_MARGIN,
    CONE_MARGIN,
    CONE_REUSE_FRACTION,
    MAX_REFINEMENTS,
    LabelConfig,
    Verification,
    VerifyConfig,
    explains_bright_spots,
    label_params,
    verify,
    wrapped_hypothesis,
)

#: an undescribed lens's k1 is fitted to this many stars reaching this far (r^2 of the
#: normalised plane: 11 deg off axis), within +-LENS_MAX_K1
LENS_MIN_STARS, LENS_MIN_R2, LENS_MAX_K1 = 6, 0.04, 0.3
#: a hypothesis the whole frame does not confirm is checked again on this many of the
#: brightest stars alone (see :func:`verify_fitted`)
BRIGHTEST = 16
#: ... only when the whole frame confirmed at least this many stars (fewer cannot pass)
BRIGHTEST_MIN_CONFIRMED = 3
#: ... against this many of the brightest catalog stars in the image: a frame's brightest
#: spots are its brightest stars (give or take a band's colours, a saturated pair), and a
#: deep catalog's faint stars, which they cannot confirm, would only raise the chance of a
#: coincidence the bound allows for (a median-subtracted frame of 14,000 spots, its right
#: answer refused against a sky cut for its field and passed against a shallower one)
BRIGHTEST_CATALOG_STARS = 2 * BRIGHTEST
#: a fitted k1 stands only where it lowers the squared pixel residuals by more than this
#: many times their variance: the 1-degree-of-freedom chi-square of the 3-sigma rule
#: (startrack.solver._calibrate_sigma). A pinhole's k1 fitted to noise would bend the
#: camera and move the attitude (tens of arcseconds at 2 px).
LENS_K1_CHI2 = SIGNIFICANCE**2
#: Gauss-Newton steps of a camera fit at most (it settles in a few where the stars fix it)
FIT_ITERATIONS = 12
#: fit-and-verify rounds at most; they stop once a round matches the same stars as the one
#: before (the next fit would start from its own optimum)
REFIT_ROUNDS = 3
#: ... past which a round also settles where its fit moved the camera by at most
#: SETTLE_FRACTION of the match radius at the farthest corner (a star at the edge of the
#: radius comes and goes with the noise); rounds still moving it after SETTLE_ROUNDS
#: (a camera fitted to a patch of stars, its scale off, gaining stars at the patch's
#: edge round after round) give no answer
SETTLE_ROUNDS = 8
SETTLE_FRACTION = 0.25


def fit_focal(camera: Camera, x: np.ndarray, y: np.ndarray, cat_vectors: np.ndarray,
              iterations: int = FIT_ITERATIONS) -> float:
    """The focal length (px) of :func:`fit_camera` with the lens left as it is."""
    return _fit(camera, x, y, cat_vectors, iterations, False)[1]  # no Camera made


def fit_camera(camera: Camera, x: np.ndarray, y: np.ndarray, cat_vectors: np.ndarray,
               iterations: int = FIT_ITERATIONS, lens: bool = True) -> Camera:
    """``camera`` with the focal length that, with its best attitude, fits the pixels
    ``x``, ``y`` to the catalog directions: the least squares of ``pixel - centre = f *
    D(tangent-plane position)`` (D the lens model) over the attitude and the focal length
    together, from Wahba's attitude at the given focal length, in at most ``iterations``
    Gauss-Newton steps (compiled: :func:`startrack._core.camera.fit.fit_focal`).
    With ``lens``, a pinhole ``camera`` and at least ``LENS_MIN_STARS`` stars reaching
    ``LENS_MIN_R2``, the radial ``k1`` too, where it lowers the residuals by more than
    ``LENS_K1_CHI2`` variances: a lens nobody described still has its wide-field stars
    fitted. A focal length that is not positive
    and finite comes back as it is; a fitted lens that folds back inside the image is an
    :class:`InputError`, as :meth:`Camera.with_distortion` makes it. A k1 beyond
    +-``LENS_MAX_K1`` is held at that bound and the rest fitted again."""
    with_k1 = lens and camera.distortion is None and len(x) >= LENS_MIN_STARS
    status, f, k1 = _fit(camera, x, y, cat_vectors, iterations, with_k1)
    cam = camera.with_focal(f)
    if status == BAD_FOCAL or not k1:
        return cam
    return cam.with_distortion(RadialDistortion(k1=k1))  # FOLDS: its InputError


def _fit(camera: Camera, x: np.ndarray, y: np.ndarray, cat_vectors: np.ndarray,
         iterations: int, with_k1: bool) -> tuple[int, float, float]:
    """The compiled fit's (status, focal length, k1)."""
    return fit_focal_kernel(camera.optics, np.ascontiguousarray(x, dtype=np.float64),
                            np.ascontiguousarray(y, dtype=np.float64),
                            np.ascontiguousarray(cat_vectors, dtype=np.float64),
                            iterations, with_k1, LENS_MIN_R2, LENS_MAX_K1, LENS_K1_CHI2)


def weighed_first(verify_with, flux: np.ndarray | None, n_stars: int):
    """``verify_with(flux)``: an answer (verification, camera, obs) or None, weighed on
    the stars' measured brightness (a false star of the wrong brightness near a catalog
    star is not named); where that answer leaves the bright spots unexplained
    (:func:`startrack.verify.explains_bright_spots`: fluxes that mislead, as on a
    stretched 8-bit frame of thousands of spots), or there is none, ``verify_with(None)``:
    the same test on the positions alone."""
    found = verify_with(flux)
    if flux is None or (found is not None and explains_bright_spots(found[0].obs_index,
                                                                     n_stars)):
        return found
    return verify_with(None)


def verify_fitted(hyp: Hypothesis, x: np.ndarray, y: np.ndarray, camera: Camera,
                  sigma_px: float, database: StarDatabase, config: VerifyConfig,
                  accepted: Verification | None = None, flux: np.ndarray | None = None,
                  ) -> tuple[Verification, Camera, Observation] | None:
    """Verify ``hyp`` with ``camera``, fit the camera to every matched star and verify
    again with the fitted camera: (verification, camera, observation of every star), None
    unless both pass. When the whole frame fails but confirms a few stars, the same test
    runs on the ``BRIGHTEST`` stars alone (a prefix: the rows stay the same), against
    the ``BRIGHTEST_CATALOG_STARS`` brightest catalog stars in the image: a deep
    camera's faint detections, mostly stars the catalog lacks, each add a chance of a
    coincidence, and the bound over the bright stars alone holds just as well. Trying
    that second set of stars is one more test per hypothesis, as one more hypothesis
    would be; the bound of each test is unchanged. ``accepted``: ``hyp``'s verification
    with ``camera`` when the caller already holds it (a refit), which is then not run
    again. ``flux``: the stars' measured fluxes (None: not measured), which the final
    labelling weighs (a false star of the wrong brightness is not named)."""
    found = _verify_fitted(hyp, x, y, camera, sigma_px, database, config, accepted, flux)
    if isinstance(found, tuple) or found < BRIGHTEST_MIN_CONFIRMED \
            or len(x) <= BRIGHTEST or np.max(hyp.obs_index) >= BRIGHTEST:
        return found if isinstance(found, tuple) else None
    bright = _verify_fitted(hyp, x[:BRIGHTEST], y[:BRIGHTEST], camera, sigma_px, database,
                            dataclasses.replace(config, catalog_stars=BRIGHTEST_CATALOG_STARS),
                            flux=None if flux is None else flux[:BRIGHTEST])
    if not isinstance(bright, tuple):
        return None
    check, fitted, _ = bright
    obs = Observation.from_pixels(x, y, fitted, sigma_px, flux)
    whole = verify(hyp, obs, database, config)  # every star labelled where it passes
    return (whole if whole.accepted else check), fitted, obs


def _verify_fitted(hyp: Hypothesis, x: np.ndarray, y: np.ndarray, camera: Camera,
                   sigma_px: float, database: StarDatabase, config: VerifyConfig,
                   accepted: Verification | None = None, flux: np.ndarray | None = None,
                   ) -> tuple[Verification, Camera, Observation] | int:
    """:func:`verify_fitted` on the stars ``x``, ``y``; when it fails, how many stars the
    first verification confirmed (0 after a failed fit or a later round). Verify, fit
    the camera to every matched star (:func:`fit_camera`), verify again through the
    fitted camera, until a round matches the stars of the one before (a fit to the
    same stars would return the same camera) or, past ``REFIT_ROUNDS``, its fit moved
    the camera by at most ``SETTLE_FRACTION`` of the match radius; rounds unsettled
    after ``SETTLE_ROUNDS`` fail (0), as does a camera whose stars fix its focal length
    to no better than a match radius at the farthest corner (a patch of stars: its
    attitude is not fixed either). In one compiled call (:func:`_compiled_rounds`).
    A round whose bound passed but whose labelling kept too few stars
    (``Verification.unlabelled``: a focal length a percent off) has its matched pairs
    fitted all the same; only an accepted round answers. A hypothesis index the
    compiled check refuses is read as :func:`startrack.verify.verify` reads it
    (negative from the end)."""
    if accepted is not None and not accepted.accepted:
        return accepted.confirmed
    found = _compiled_rounds(hyp, x, y, camera, sigma_px, database, config, accepted, flux)
    if found is not None:
        return found
    wrapped = wrapped_hypothesis(np.asarray(hyp.obs_index, np.int64),
                                 np.asarray(hyp.cat_index, np.int64), len(x),
                                 len(database.vectors))
    if wrapped is None:
        return 0  # verify refuses it: nothing confirmed
    found = _compiled_rounds(Hypothesis(*wrapped), x, y, camera, sigma_px, database, config,
                             accepted, flux)
    return 0 if found is None else found


def _compiled_rounds(hyp: Hypothesis, x: np.ndarray, y: np.ndarray, camera: Camera,
                     sigma_px: float, database: StarDatabase, config: VerifyConfig,
                     accepted: Verification | None, flux: np.ndarray | None = None,
                     ) -> tuple[Verification, Camera, Observation] | int | None:
    """:func:`_verify_fitted`'s answer from one compiled call
    (:class:`startrack._core.solver.fitted_rounds.FittedRounds`); None where the compiled check
    refuses a hypothesis index (to wrap, or refuse, as :func:`startrack.verify.verify`
    does)."""
    x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)  # from_pixels's
    rounds = rounds_for(x, y, camera, sigma_px, database, config, flux)
    held = (None, None, 0) if accepted is None else (
        _as(accepted.obs_index, np.int64), _as(accepted.cat_index, np.int64),
        accepted.confirmed)
    found = rounds.run(_as(hyp.obs_index, np.int64), _as(hyp.cat_index, np.int64),
                       camera.f_px, *held)
    if not isinstance(found, tuple):
        return found
    verdict, f, k1, vectors = found
    # fit_camera's camera: the focal length replaced, and a k1 once one was fitted
    fitted = camera.with_focal(f) if not k1 else Camera(
        camera.width, camera.height, f, camera.cx, camera.cy, RadialDistortion(k1=k1))
    obs = Observation(vectors, x, y, fitted, float(sigma_px) / fitted.f_px,
                      None if flux is None else _as(flux))
    check = Verification._of(True, verdict.final, verdict.obs, verdict.rows,
                             verdict.probability, verdict.confirmed, verdict.residuals,
                             verdict.quaternion, vectors)
    return check, fitted, obs


def rounds_for(x: np.ndarray, y: np.ndarray, camera: Camera, sigma_px: float,
               database: StarDatabase, config: VerifyConfig,
               flux: np.ndarray | None = None) -> FittedRounds:
    """The compiled rounds of the stars at pixels ``x``, ``y`` (float64), with fluxes
    ``flux`` (None: not measured), seen through ``camera`` (its focal length is each
    run's), verified under ``config``: a copy of the rounds made once for that camera,
    noise, settings and whether fluxes are measured, held by ``database`` (they read its
    tables, and go with them: a blind search's evicted cut is not kept alive)."""
    held = database.__dict__.setdefault("_fitted_rounds", {})
    key = (camera.width, camera.height, camera.cx, camera.cy, camera.distortion,
           float(sigma_px), config, flux is not None)
    rounds = held.get(key)
    if rounds is None:
        if len(held) >= ROUNDS_KEPT:
            held.clear()
        rounds = held[key] = _rounds(camera, sigma_px, database, config, flux is not None)
    return rounds.with_pixels(_as(x), _as(y), None if flux is None else _as(flux))


def _rounds(camera: Camera, sigma_px: float, database: StarDatabase,
            config: VerifyConfig, has_flux: bool = False) -> FittedRounds:
    """The rounds of ``camera``, ``database`` and ``config``, with no stars yet."""
    fixed = config.match_radius_px is not None
    no_pixels = np.zeros(0)
    # the labelling's thresholds of this image size (and whether it weighs brightness);
    # the rounds set the scales
    label = label_params(Observation(_NO_VECTORS, no_pixels, no_pixels, camera, 1.0,
                                     no_pixels if has_flux else None), 1.0)
    params = {"radius_px": 0.0, "cos_radius": 0.0, "cone_radius": 0.0, "margin_cos": 0.0,
              "capture": CAPTURE, "max_rounds": MAX_REFINEMENTS,
              "min_confirmed": config.min_confirmed,
              "max_probability": config.max_false_probability,
              "max_stars": config.catalog_stars, "label": label}
    frame = {"cx": camera.cx, "cy": camera.cy, "width": camera.width,
             "height": camera.height, "corner_r": camera.corner_radius_px,
             "sigma_px": float(sigma_px), "fixed_radius": fixed,
             "match_radius": float(config.match_radius_px) if fixed else 0.0,
             "radius_sigma": config.radius_sigma, "min_radius": config.min_radius_px}
    return FittedRounds(no_pixels, no_pixels,
                        None if camera.distortion is None else camera.distortion.compiled,
                        frame, _CONSTANTS, params, database.cone_index.table,
                        _as(database.catalog.mag), _as(database.vectors))


def _as(array: np.ndarray, dtype: type = np.float64) -> np.ndarray:
    return np.ascontiguousarray(array, dtype=dtype)


_NO_VECTORS = np.zeros((0, 3))
#: rounds (without stars) a database holds, one per camera (its focal length aside),
#: centroid noise and settings met lately: made once, copied for each frame's pixels
ROUNDS_KEPT = 16
#: the solver's constants as the compiled rounds take them (a FitConstants): the
#: labelling's (label_params' defaults), the catalog cone's, fit_camera's, and
#: math.radians and math.degrees as the one product each is
_CONSTANTS = {"resolve_px": float(LabelConfig().resolve_px),
              "resolve_sigmas": LabelConfig().resolve_sigmas, "cone_margin": CONE_MARGIN,
              "lookup_margin": CONE_LOOKUP_MARGIN, "reuse_fraction": CONE_REUSE_FRACTION,
              "lens_min_stars": LENS_MIN_STARS, "lens_min_r2": LENS_MIN_R2,
              "lens_max_k1": LENS_MAX_K1, "lens_k1_chi2": LENS_K1_CHI2,
              "iterations": FIT_ITERATIONS,
              "rounds": REFIT_ROUNDS, "settle_rounds": SETTLE_ROUNDS,
              "settle_fraction": SETTLE_FRACTION, "rad": math.radians(1.0),
              "deg": math.degrees(1.0)}
