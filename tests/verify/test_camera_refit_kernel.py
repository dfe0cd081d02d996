"""The compiled camera refit (startrack/_core/verify/camera_refit.pyx) against its numpy
reference (refit_reference.py): the same pairs, the same fitted camera to rounding, the
same centre direction and its move (the pseudo-inverse held to numpy's), the same
brightest stars in view, on cameras that fit, that lack a lens term, that are off, and on
spots too few to fit."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
import refit_reference as reference
from scipy.spatial.transform import Rotation

from startrack._core.verify import camera_refit
from startrack.camera import Camera, RadialDistortion
from startrack.sky import SkySpec, load_sky
from startrack.verify._refit import CATALOG_STARS, RULES, SPOTS, brightest_in_view

CAMERA = Camera.from_fov(1024, 1024, 12.0)


def _case(seed: int):
    """Catalog vectors (60, the answer's camera frame) and 40 spots of a camera that may
    be off: a tilted attitude, a lens term the camera lacks, a moved centre, noise, and
    a few spots with no star (all seeded)."""
    rng = np.random.default_rng(seed)
    x, y = rng.uniform(20, 1004, (2, CATALOG_STARS))
    v = CAMERA.pixel_to_vector(x, y)
    true = dataclasses.replace(CAMERA, cx=CAMERA.cx + rng.normal(0, 3),
                               distortion=RadialDistortion(k1=rng.uniform(-0.2, 0.2)))
    sx, sy, _ = true.vector_to_pixel(v)
    sx, sy = sx + rng.normal(0, 0.3, sx.shape), sy + rng.normal(0, 0.3, sy.shape)
    false = rng.random(len(sx)) < 0.1
    sx[false], sy[false] = rng.uniform(0, 1024, (2, false.sum()))
    tilt = Rotation.from_rotvec(rng.normal(0, 2.0 / CAMERA.f_px, 3))
    order = rng.permutation(len(sx))[:SPOTS]
    return (np.ascontiguousarray(tilt.apply(v)), np.ascontiguousarray(sx[order]),
            np.ascontiguousarray(sy[order]))


def _start():
    return np.array([0.0, 0.0, 0.0, CAMERA.f_px, CAMERA.cx, CAMERA.cy, 0.0])


@pytest.mark.parametrize("seed", range(12))
def test_the_kernel_pairs_as_the_reference(seed):
    v, x, y = _case(seed)
    for limit in (1.0, 4.0, 50.0):
        got = camera_refit.pairs(_start(), v, x, y, limit)
        want = reference.pairs(_start(), v, x, y, limit)
        assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])


@pytest.mark.parametrize("seed", range(12))
def test_the_kernel_fits_the_camera_the_reference_fits(seed):
    v, x, y = _case(seed)
    p = _start()
    fitted = camera_refit.fit_rounds(p, v, x, y, 2.0, RULES)
    want = reference.fit_rounds(_start(), v, x, y, 2.0)
    assert (fitted is None) == (want is None)
    if want is None:
        return
    p_want, r, jac = want
    # the two stop within the fit's convergence test (steps of 1e-7 relative) of each
    # other: every star where the reference's camera puts it to a thousandth of a pixel
    got_x, got_y = reference._pixels(p[None], v)
    want_x, want_y = reference._pixels(p_want[None], v)
    assert np.hypot(got_x - want_x, got_y - want_y).max() < 1e-3
    r2, residuals, jtj = fitted
    assert residuals == len(r)
    assert r2 == pytest.approx(r @ r, rel=1e-6, abs=1e-9)
    # the kernel's Jacobian is analytic, the reference's forward differences: their
    # normal matrices agree to the differences' error, relative to each entry's scale
    want = jac.T @ jac
    scale = np.sqrt(np.outer(np.diag(want), np.diag(want)))
    assert np.abs((jtj - want) / scale).max() < 1e-4


def test_a_round_with_too_few_pairs_fits_nothing():
    v, x, y = _case(0)
    p = _start()
    far = camera_refit.fit_rounds(p, v, x + 500.0, y, 2.0, RULES)
    assert far is None
    assert reference.fit_rounds(_start(), v, x + 500.0, y, 2.0) is None


@pytest.mark.parametrize("pixel", [(511.5, 511.5), (0.0, 0.0), (1000.0, 20.0)])
def test_the_centre_direction_is_the_references(pixel):
    p = np.array([1e-3, -2e-3, 0.5, 4000.0, 520.0, 500.0, -0.1])
    np.testing.assert_allclose(camera_refit.centre(p, *pixel), reference.centre(p, *pixel),
                               rtol=0, atol=1e-14)


def _move_in_numpy(p, fitted, sigma_px):
    """The centre's move and its 1-sigma as startrack.verify._refit computed them in
    numpy before the kernel did: numpy's pinv, forward differences of the centre."""
    r2, residuals, jtj = fitted
    cov = max(r2 / max(1, residuals - 7), sigma_px ** 2) * np.linalg.pinv(jtj)
    cx0, cy0 = (CAMERA.width - 1) / 2.0, (CAMERA.height - 1) / 2.0
    given = CAMERA.pixel_to_vector(np.array([cx0]), np.array([cy0]))[0]
    centre = np.array(camera_refit.centre(p, cx0, cy0))
    steps = np.sqrt(np.maximum(np.diagonal(cov), 0.0)) * 1e-3 + 1e-12
    grad = np.empty((2, 7))
    for k in range(7):
        q = p.copy()
        q[k] += steps[k]
        grad[:, k] = (np.array(camera_refit.centre(q, cx0, cy0)) - centre) / (q[k] - p[k])
    shift = float(np.hypot(*(centre - given[:2] / given[2]))) * CAMERA.f_px
    return shift, math.sqrt(max(float(np.trace(grad @ cov @ grad.T)), 0.0)) * CAMERA.f_px


@pytest.mark.parametrize("seed", range(12))
def test_the_one_call_refit_moves_the_centre_as_numpy_did(seed):
    v, x, y = _case(seed)
    p = _start()
    fitted = camera_refit.fit_rounds(p, v, x, y, 2.0, RULES)
    got = camera_refit.refit(CAMERA.optics, v, x, y, 2.0, 0.5, RULES)
    assert (got is None) == (fitted is None)
    if fitted is None:
        return
    spots, shift, sigma = got
    want_shift, want_sigma = _move_in_numpy(p, fitted, 0.5)
    assert shift == pytest.approx(want_shift, abs=1e-9)
    assert sigma == pytest.approx(want_sigma, rel=1e-6)
    np.testing.assert_array_equal(spots, camera_refit.pairs(p, v, x, y, 2.0)[0])


def test_the_rules_take_one_k1_flag_per_round():
    with pytest.raises(ValueError, match="one k1 flag per round"):
        camera_refit.RefitRules([3.0, 1.0], [0], 8, 40, 1e-3)


@pytest.mark.parametrize("seed", range(8))
def test_the_pseudo_inverse_is_numpys_where_the_rank_is_full(seed):
    rng = np.random.default_rng(seed)
    # a refit's units: radians x focal length, pixels, k1 x focal length
    jac = rng.normal(size=(80, 7)) * np.array([1e4, 1e4, 1e4, 1.0, 1.0, 1.0, 1e3])
    jac[:, 4] = jac[:, 0] * 2e-4 + rng.normal(size=80) * 1e-3  # nearly traded off
    a = jac.T @ jac
    want = np.linalg.pinv(a)
    got = camera_refit.symmetric_pinv(a)
    assert np.abs(got - want).max() <= 1e-7 * np.abs(want).max()


@pytest.mark.parametrize("dependent", ["zero column", "equal columns"])
def test_the_pseudo_inverse_of_a_singular_matrix_is_one(dependent):
    rng = np.random.default_rng(5)
    jac = rng.normal(size=(80, 7)) * np.array([1e4, 1e4, 1e4, 1.0, 1.0, 1.0, 1e3])
    if dependent == "zero column":
        jac[:, 6] = 0.0  # k1 held: nothing constrains it
    else:
        jac[:, 4] = jac[:, 0] * 2e-4
    a = jac.T @ jac
    x = camera_refit.symmetric_pinv(a)
    # the Moore-Penrose conditions, to rounding
    assert np.abs(a @ x @ a - a).max() <= 1e-12 * np.abs(a).max()
    assert np.abs(x @ a @ x - x).max() <= 1e-12 * np.abs(x).max()
    np.testing.assert_allclose(x, x.T, rtol=0, atol=1e-12 * np.abs(x).max())
    if dependent == "zero column":
        assert not x[6].any() and not x[:, 6].any()


@pytest.mark.parametrize("distorted", [False, True])
def test_the_brightest_in_view_are_numpys_selection(distorted):
    camera = CAMERA if not distorted else dataclasses.replace(
        CAMERA, distortion=RadialDistortion(k1=-0.2))
    catalog = load_sky(SkySpec(kind="hipparcos", mag_limit=7.0), camera)
    rng = np.random.default_rng(11)
    for rotation in Rotation.random(20, random_state=rng):
        matrix = rotation.as_matrix()
        rows, v = brightest_in_view(catalog.vectors, matrix, camera)
        # the selection as numpy made it: every star's product, a sort by magnitude
        near = np.flatnonzero(catalog.vectors @ matrix[:, 2] > math.cos(
            math.radians(camera.half_diagonal_deg)))
        cx, cy, front = camera.vector_to_pixel(catalog.vectors[near] @ matrix)
        seen = near[front & camera.in_image(cx, cy)]
        want = seen[np.argsort(catalog.mag[seen], kind="stable")][:CATALOG_STARS]
        np.testing.assert_array_equal(rows, want)
        np.testing.assert_allclose(v, catalog.vectors[want] @ matrix, rtol=0, atol=1e-15)


def test_the_k1_score_is_numpys():
    """The kernel's test of whether the pairs support k1 (the rounds that free it are
    skipped where they do not) decides as the score statistic in numpy does, on every
    case whose rounds fit (10 of the 12 seeded ones)."""
    held = camera_refit.RefitRules([3.0, 2.0, 1.0], [0, 0, 0], 8, 40, 1e-7)
    checked = 0
    for seed in range(12):
        v, x, y = _case(seed)
        p = _start()
        if camera_refit.fit_rounds(p, v, x, y, 2.0, held) is None:
            continue
        spots, stars = camera_refit.pairs(p, v, x, y, 2.0)
        r, jac = reference._jacobian(p, v[stars], x[spots], y[spots])
        statistic = reference.k1_statistic(r, jac)
        assert statistic > 0.0
        assert camera_refit.k1_score(p, v, x, y, spots, stars, statistic * 1.001)
        assert not camera_refit.k1_score(p, v, x, y, spots, stars, statistic * 0.999)
        checked += 1
    assert checked >= 10


def test_a_lens_the_camera_lacks_keeps_the_k1_rounds_and_none_skips_them():
    """Spots through a k1 of -0.15 the camera lacks: the score is far past K1_CHI2 and
    the refit fits k1; through the camera's own lens the k1 rounds are skipped, the
    answer that of the rounds that held k1."""
    rng = np.random.default_rng(3)
    x, y = rng.uniform(20, 1004, (2, 60))
    v = np.ascontiguousarray(CAMERA.pixel_to_vector(x, y))
    held = camera_refit.RefitRules([3.0, 2.0, 1.0], [0, 0, 0], 8, 40, 1e-7)
    for k1, skipped in ((-0.15, False), (0.0, True)):
        lens = dataclasses.replace(CAMERA, distortion=RadialDistortion(k1=k1) if k1 else None)
        sx, sy, _ = lens.vector_to_pixel(v)
        sx = np.ascontiguousarray(sx[:40] + rng.normal(0, 0.2, 40))
        sy = np.ascontiguousarray(sy[:40] + rng.normal(0, 0.2, 40))
        full, no_k1 = _start(), _start()
        camera_refit.fit_rounds(full, v, sx, sy, 2.0, RULES)
        camera_refit.fit_rounds(no_k1, v, sx, sy, 2.0, held)
        assert (full[6] == 0.0) == skipped
        if skipped:
            np.testing.assert_array_equal(full, no_k1)
        else:
            assert full[6] == pytest.approx(-0.15, abs=0.02)
