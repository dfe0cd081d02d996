"""The fitted camera (startrack.solver._fov_fit): focal length, and k1 of an undescribed lens."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from startrack._core.shared import wahba
from synth import synthetic_frame

from startrack.attitude import random_attitudes
from startrack.camera import Camera, RadialDistortion
from startrack.database import StarDatabase
from startrack.match_records import Hypothesis, Observation
from startrack.sky import random_sky
from startrack.solver._fov_fit import (
    FIT_ITERATIONS,
    LENS_K1_CHI2,
    LENS_MAX_K1,
    LENS_MIN_R2,
    LENS_MIN_STARS,
    fit_camera,
    fit_focal,
    verify_fitted,
)
from startrack.solver._fov_given import keep_given
from startrack.solver._lost_in_space import residuals_arcsec
from startrack.verify import VerifyConfig


def _stars(camera: Camera, n: int, seed: int):
    rng = np.random.default_rng(seed)
    x = rng.uniform(0, camera.width - 1, n)
    y = rng.uniform(0, camera.height - 1, n)
    return x, y, Rotation.random(random_state=seed).apply(camera.pixel_to_vector(x, y))


def test_a_wide_undescribed_lens_has_its_k1_fitted():
    true = Camera.from_fov(3000, 2000, 35.0, distortion=RadialDistortion(k1=-0.1))
    x, y, sky = _stars(true, 40, 3)
    told = dataclasses.replace(true.pinhole, f_px=true.f_px * 1.04)
    fitted = fit_camera(told, x, y, sky)
    assert fitted.distortion is not None
    assert fitted.distortion.k1 == pytest.approx(-0.1, abs=1e-6)
    assert fitted.f_px == pytest.approx(true.f_px, rel=1e-8)
    # the focal length alone leaves pixels of error at the corners
    alone = dataclasses.replace(told, f_px=fit_focal(told, x, y, sky))
    assert alone.distortion is None and abs(alone.f_px / true.f_px - 1) > 1e-4


def test_a_k1_stands_only_where_the_stars_demand_it():
    """A pinhole's noisy stars give no k1 (a k1 fitted to noise bends the camera and
    moves the attitude); a real lens's noisy stars keep theirs."""
    rng = np.random.default_rng(12)
    pinhole = Camera.from_fov(1024, 1024, 20.0)
    lens = Camera.from_fov(1024, 1024, 20.0, distortion=RadialDistortion(k1=-0.2))
    bent = 0
    for seed in range(20):
        x, y, sky = _stars(pinhole, 40, 100 + seed)
        noisy = x + rng.normal(0, 2.0, 40), y + rng.normal(0, 2.0, 40)
        bent += fit_camera(pinhole.with_focal(pinhole.f_px * 1.03), *noisy,
                           sky).distortion is not None
        x, y, sky = _stars(lens, 40, 200 + seed)
        fitted = fit_camera(lens.pinhole.with_focal(lens.f_px * 1.03),
                            x + rng.normal(0, 0.5, 40), y + rng.normal(0, 0.5, 40), sky)
        assert fitted.distortion is not None
        assert fitted.distortion.k1 == pytest.approx(-0.2, abs=0.03)
    assert bent <= 2  # a 3-sigma rule lets chance through about once in 370 fits each


def test_a_narrow_field_or_few_stars_fit_the_focal_length_only():
    narrow = Camera.from_fov(1024, 768, 5.0)
    x, y, sky = _stars(narrow, 40, 4)  # no star reaches the lens-fitting radius
    fitted = fit_camera(dataclasses.replace(narrow, f_px=narrow.f_px * 0.97), x, y, sky)
    assert fitted.distortion is None
    assert fitted.f_px == pytest.approx(narrow.f_px, rel=1e-8)
    wide = Camera.from_fov(1024, 768, 30.0)
    x, y, sky = _stars(wide, LENS_MIN_STARS - 1, 5)
    assert fit_camera(wide, x, y, sky).distortion is None


def test_a_described_lens_is_kept():
    lens = RadialDistortion(k1=-0.05)
    true = Camera.from_fov(2000, 1500, 25.0, distortion=lens)
    x, y, sky = _stars(true, 30, 6)
    fitted = fit_camera(dataclasses.replace(true, f_px=true.f_px * 1.03), x, y, sky)
    assert fitted.distortion == lens
    assert fitted.f_px == pytest.approx(true.f_px, rel=1e-8)


def _fit_or_error(fit, *args, **kwargs):
    from startrack.errors import InputError

    try:
        return fit(*args, **kwargs)
    except InputError as exc:
        return str(exc)


def _fitted_cost(camera: Camera, f: float, k1: float, x, y, sky) -> float:
    """The least squared pixel residuals at focal length ``f`` and k1 over the attitude
    alone (scipy, from the Wahba attitude through that camera)."""
    from fov_fit_reference import pixel_residuals
    from scipy.optimize import least_squares

    from startrack.attitude import wahba_matrices

    through = dataclasses.replace(camera, f_px=f)
    if k1:
        through = through.with_distortion(RadialDistortion(k1=k1))
    start = wahba_matrices(through.pixel_to_vector(x, y), sky)
    found = least_squares(
        lambda w: pixel_residuals(camera, start @ Rotation.from_rotvec(w).as_matrix(), f,
                                  k1, x, y, sky),
        np.zeros(3), method="lm", xtol=1e-15, ftol=1e-15, gtol=1e-15)
    return float(np.sum(found.fun**2))


def test_the_compiled_fit_is_the_least_squares_optimum():
    """The compiled fit reaches scipy's least-squares optimum of the same residuals from
    the same start (tests/solver/fov_fit_reference.py), over cameras with and without a
    described lens, undescribed lenses whose k1 is fitted (or held at its bound), noisy
    and wrong pairs, and few stars: never a worse fit, and the same focal length and k1
    wherever the stars fix them."""
    from fov_fit_reference import reference_fit

    rng = np.random.default_rng(41)
    kinds = {"same": 0, "k1": 0, "bound": 0, "folds": 0}
    trials = 0
    for t in range(240):
        fov = float(rng.choice([3.0, 12.0, 25.0, 45.0, 70.0]))
        lens = (None, RadialDistortion(k1=float(rng.uniform(-0.2, 0.1))),
                RadialDistortion(k1=-0.05, k2=0.01, k3=-0.002))[t % 3]
        if t >= 200:  # lenses beyond the fitted k1's bound: held there, or folding
            fov, lens = float(rng.choice([45.0, 70.0])), RadialDistortion(
                k1=float(rng.choice([0.6, -0.4])), k2=0.1)
        size = int(rng.integers(400, 3000)), int(rng.integers(300, 2000))
        true = _fit_or_error(Camera.from_fov, *size, fov, distortion=lens)
        if isinstance(true, str):  # a lens that folds inside this field: no such camera
            continue
        n = int(rng.integers(3, 60))
        x, y, sky = _stars(true, n, t)
        x = x + rng.normal(0.0, (0.0, 0.3, 3.0)[t % 3], n)
        if t % 7 == 0:  # some wrong pairs
            sky[: n // 3] = sky[rng.permutation(n // 3)]
        told = dataclasses.replace(true if t % 2 else true.pinhole,
                                   f_px=true.f_px * float(rng.uniform(0.85, 1.15)))
        lens_fit = t % 11 != 0
        f_ref, k1_ref, cost_ref = reference_fit(told, x, y, sky, lens_fit)
        got = _fit_or_error(fit_camera, told, x, y, sky, 12, lens_fit)
        trials += 1
        if isinstance(got, str):  # the optimum's lens folds back inside the image
            assert "folds back inside the image" in got
            assert isinstance(_fit_or_error(told.with_distortion,
                                            RadialDistortion(k1=k1_ref)), str)
            kinds["folds"] += 1
            continue
        k1 = 0.0 if got.distortion is None or got.distortion == told.distortion \
            else got.distortion.k1
        cost = _fitted_cost(told, got.f_px, k1, x, y, sky)
        assert cost <= cost_ref * (1 + 1e-8) + 1e-12, (t, cost, cost_ref)
        same = got.f_px == pytest.approx(f_ref, rel=1e-7) and k1 == pytest.approx(
            k1_ref, abs=1e-7)
        kinds["same"] += same
        kinds["k1"] += k1 != 0.0
        kinds["bound"] += abs(k1) == LENS_MAX_K1
    assert kinds["same"] >= 0.9 * (trials - kinds["folds"]), kinds
    assert min(kinds.values()) > 0, kinds


def test_stars_clustered_off_the_axis_fit_the_focal_length():
    """Stars in one small patch near the edge let a turn of the attitude stand in for a
    change of scale: the fit must still reach the focal length the pixels give, where
    twelve alternations of Wahba's attitude and the focal length stopped 0.7% short
    (a wrong attitude with every identity right)."""
    true = Camera.from_fov(1024, 1024, 20.0)
    rng = np.random.default_rng(7)
    x, y = rng.uniform(780, 950, 13), rng.uniform(340, 510, 13)
    sky = Rotation.random(random_state=7).apply(true.pixel_to_vector(x, y))
    told = true.with_focal(true.f_px * 0.991)
    fitted = fit_camera(told, x, y, sky, lens=False)
    assert fitted.f_px == pytest.approx(true.f_px, rel=1e-9)
    noisy = fit_camera(told, x + rng.normal(0, 0.3, 13), y + rng.normal(0, 0.3, 13), sky,
                       lens=False)
    assert abs(noisy.f_px / true.f_px - 1) < 0.003


def test_a_fitted_verification_holds_the_residuals_keep_given_measures():
    """keep_given takes the fitted camera's residuals from its verification: they are the
    Wahba fit of the reported pairs and their angles on the observation returned, to the
    bit; a given camera it keeps comes back with the frame's stars through that camera."""
    db = StarDatabase(random_sky(3000, seed=3), Camera.from_fov(1024, 1024, 20.0))
    rng = np.random.default_rng(8)
    checked = given = 0
    for rot in random_attitudes(8, rng):
        frame = synthetic_frame(db.catalog, db.camera, rot, rng, noise_px=0.3)
        real = np.flatnonzero(frame.truth_rows >= 0)[:4]
        told = db.camera.with_focal(db.camera.f_px * 1.001)
        found = verify_fitted(Hypothesis(real, frame.truth_rows[real]), frame.obs.x,
                              frame.obs.y, told, 0.3, db, VerifyConfig())
        if found is None:
            continue
        check, _, obs = found
        assert check.obs_vectors is obs.vectors and len(check.obs_index) >= 3
        cat = np.ascontiguousarray(db.vectors[check.cat_index])
        rotation = wahba(np.ascontiguousarray(obs.vectors[check.obs_index]), cat)
        np.testing.assert_array_equal(check.residual_arcsec,
                                      residuals_arcsec(rotation, obs, check.obs_index, cat))
        kept = keep_given(found, db.camera, 0.3, db, VerifyConfig())
        if kept[1] is db.camera:
            through = Observation.from_pixels(frame.obs.x, frame.obs.y, db.camera, 0.3)
            np.testing.assert_array_equal(kept[2].vectors, through.vectors)
            assert kept[0].obs_vectors is kept[2].vectors
        else:
            assert kept is found
        given += kept[1] is db.camera
        checked += 1
    assert checked >= 6 and given >= 3


def test_the_given_cameras_rejection_thresholds_are_scipys_quantiles():
    """The closed forms keep_given uses agree with scipy.stats, which the solver no
    longer imports: the two-sided 3-sigma tail and its chi-square quantiles."""
    from scipy.stats import chi2, norm

    from startrack.solver import _fov_given as _fov_fit

    p = 2.0 * float(norm.sf(3.0))
    assert pytest.approx(p, rel=1e-12) == _fov_fit.GIVEN_REJECT_P
    for n in (1, 2):
        assert _fov_fit._GIVEN_REJECT_CHI2[n] == pytest.approx(float(chi2.isf(p, n)),
                                                                rel=1e-12)


@pytest.mark.parametrize("distortion", [None, RadialDistortion(k1=-0.05, k2=0.01)])
def test_a_cameras_residuals_are_the_python_composition_bit_for_bit(distortion):
    """keep_given's chi-square of a camera (squared_residuals): pixel_to_vector, the Wahba
    attitude of the matched pairs and their residuals, as the Python calls compose them,
    squared and summed in order; and given_stands' one call (fit_against): fit_camera's
    camera and both cameras' chi-squares."""
    from startrack._core.camera.fit import SETTLED, fit_against, squared_residuals

    camera = Camera.from_fov(1024, 768, 20.0, distortion=distortion)
    db = StarDatabase(random_sky(3000, seed=3), camera.pinhole)
    rng = np.random.default_rng(3)
    frame = synthetic_frame(db.catalog, camera, random_attitudes(1, rng)[0], rng,
                            noise_px=0.5, false_stars=2)
    obs_index = np.flatnonzero(frame.truth_rows >= 0)
    rows = frame.truth_rows[obs_index].astype(np.int64)
    cat = np.ascontiguousarray(db.vectors[rows])
    x, y = frame.obs.x, frame.obs.y

    def composed(cam: Camera) -> np.ndarray:
        obs = Observation.from_pixels(x, y, cam, 0.5)
        matrix = wahba(np.ascontiguousarray(obs.vectors[obs_index]), cat)
        return residuals_arcsec(matrix, obs, obs_index, cat)

    def in_order(residuals: np.ndarray) -> float:
        total = 0.0
        for r in residuals.tolist():
            total += r * r
        return total

    told = camera.with_focal(camera.f_px * 1.003)
    want = composed(told)
    got = squared_residuals(told.optics, x, y, obs_index, rows, db.vectors)
    assert got == in_order(want) and len(want) >= 10
    assert np.median(want) > 1.0  # a focal length 0.3% off shows in the residuals
    fitted = fit_camera(told, x[obs_index], y[obs_index], cat)
    status, f, k1, told_sq, fit_sq = fit_against(
        told.optics, x, y, obs_index, cat, FIT_ITERATIONS, distortion is None,
        LENS_MIN_R2, LENS_MAX_K1, LENS_K1_CHI2)
    assert status == SETTLED and f == fitted.f_px and told_sq == got
    assert k1 == (0.0 if fitted.distortion == told.distortion else fitted.distortion.k1)
    assert fit_sq == in_order(composed(fitted)) and fit_sq < told_sq / 2
    with pytest.raises(IndexError):
        squared_residuals(told.optics, x, y, obs_index + len(x), rows, db.vectors)
    with pytest.raises(IndexError):
        squared_residuals(told.optics, x, y, obs_index, rows + len(db.vectors), db.vectors)
    with pytest.raises(ValueError):
        squared_residuals(told.optics, x, y[:-1], obs_index, rows, db.vectors)
    with pytest.raises(ValueError):
        fit_against(told.optics, x, y, obs_index, cat[:-1], 12, False, 0.04, 0.3, 9.0)
