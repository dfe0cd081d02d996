"""The compiled camera refit (startrack/_core/verify/camera_refit.pyx) against its numpy
reference (refit_reference.py): the same pairs, the same fitted camera to rounding, the
same centre direction, on cameras that fit, that lack a lens term, that are off, and on
spots too few to fit."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import refit_reference as reference
from scipy.spatial.transform import Rotation

from startrack._core.verify import camera_refit
from startrack.camera import Camera, RadialDistortion
from startrack.verify._refit import (
    _FACTORS,
    _FREE_K1,
    CATALOG_STARS,
    DAMPING,
    ITERATIONS,
    MIN_PAIRS,
    SPOTS,
)

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
    fitted = camera_refit.fit_rounds(p, v, x, y, 2.0, _FACTORS, _FREE_K1, MIN_PAIRS,
                                     ITERATIONS, DAMPING)
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
    far = camera_refit.fit_rounds(p, v, x + 500.0, y, 2.0, _FACTORS, _FREE_K1, MIN_PAIRS,
                                  ITERATIONS, DAMPING)
    assert far is None
    assert reference.fit_rounds(_start(), v, x + 500.0, y, 2.0) is None


@pytest.mark.parametrize("pixel", [(511.5, 511.5), (0.0, 0.0), (1000.0, 20.0)])
def test_the_centre_direction_is_the_references(pixel):
    p = np.array([1e-3, -2e-3, 0.5, 4000.0, 520.0, 500.0, -0.1])
    np.testing.assert_allclose(camera_refit.centre(p, *pixel), reference.centre(p, *pixel),
                               rtol=0, atol=1e-14)
