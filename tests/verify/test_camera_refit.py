"""Issue 49: the evidence gate refits the camera (attitude, focal length, principal point,
k1) to the brightest stars; the image centre's move is the answer's error. Right answers
whose labels the final labelling withheld (real frames: saturated spots, thousands of
false spots) stand; answers the move shows to be off are refused."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from startrack.camera import Camera, RadialDistortion
from startrack.sky import SkySpec, load_sky
from startrack.verify._evidence import _labels_problem, camera_problem
from startrack.verify._refit import CATALOG_STARS, refit_stars
from tests.solver.test_principal_point import FOV, SIZE, _solved

CAMERA = Camera.from_fov(SIZE, SIZE, FOV)


@pytest.fixture(scope="module")
def hipparcos():
    return load_sky(SkySpec(kind="hipparcos", mag_limit=6.5), CAMERA)


def _stars(seed: int, through: Camera, noise_px: float = 0.2):
    """Camera-frame vectors of 60 stars in view, and their spots through ``through``
    with ``noise_px`` of noise (seeded), in the same order."""
    rng = np.random.default_rng(seed)
    x, y = rng.uniform(20, SIZE - 20, (2, CATALOG_STARS))
    v = CAMERA.pixel_to_vector(x, y)
    sx, sy, _ = through.vector_to_pixel(v)
    return v, sx + rng.normal(0, noise_px, sx.shape), sy + rng.normal(0, noise_px, sy.shape)


def test_a_camera_that_fits_does_not_move():
    v, x, y = _stars(1, CAMERA)
    refit = refit_stars(v, x, y, CAMERA, 2.0, 0.5)
    assert refit is not None and len(refit.explained) == CATALOG_STARS
    assert refit.shift_px < 0.1 and refit.sigma_px < 0.3


def test_a_lens_the_camera_lacks_is_fitted_without_moving_the_centre():
    # k1 = -0.3: 11 px at the corners, where the pinhole answer misses most stars
    v, x, y = _stars(2, dataclasses.replace(CAMERA, distortion=RadialDistortion(k1=-0.3)))
    refit = refit_stars(v, x, y, CAMERA, 2.0, 0.5)
    assert refit is not None and len(refit.explained) >= 0.9 * CATALOG_STARS
    assert refit.shift_px < 0.2


@pytest.mark.parametrize("off_px", [1.5, 4.0])
def test_the_centre_moves_by_the_answers_error(off_px):
    v, x, y = _stars(3, CAMERA)
    # the answer's attitude off by off_px at the centre: its catalog stars rotated so
    tilt = Rotation.from_rotvec([off_px / CAMERA.f_px, 0.0, 0.0])
    refit = refit_stars(tilt.apply(v), x, y, CAMERA, 2.0, 0.5)
    assert refit is not None
    assert refit.shift_px == pytest.approx(off_px, abs=0.1)


def _frame_with_labels(hipparcos, keep: int):
    """A solved simulated frame whose labels among the 20 brightest spots are cut to
    ``keep`` (as the final labelling withholds saturated or crowded stars)."""
    frame = _solved(hipparcos)
    sol = frame.solution
    bright = np.flatnonzero(sol.obs_index < 20)
    drop = np.zeros(len(sol.obs_index), bool)
    drop[bright[keep:]] = True
    cut = dataclasses.replace(sol, obs_index=sol.obs_index[~drop],
                              cat_index=sol.cat_index[~drop],
                              residual_arcsec=sol.residual_arcsec[~drop])
    return frame, cut


def test_a_right_answer_with_withheld_labels_stands(hipparcos):
    frame, cut = _frame_with_labels(hipparcos, 3)
    args = (frame.obs, frame.camera, frame.catalog)
    assert "brightest spots" in _labels_problem(cut, *args)  # the old rule refused it
    assert camera_problem(cut, *args, frame.match_radius_px, frame.sigma_px) is None


def test_an_answer_off_by_pixels_is_refused_even_fully_labelled(hipparcos):
    frame, _ = _frame_with_labels(hipparcos, 20)
    sol = frame.solution
    args = (frame.obs, frame.camera, frame.catalog, frame.match_radius_px, frame.sigma_px)
    assert camera_problem(sol, *args) is None
    off = sol.rotation * Rotation.from_rotvec([0.0, 3.0 / frame.camera.f_px, 0.0])
    why = camera_problem(dataclasses.replace(sol, rotation=off), *args)
    assert why is not None and "moves 3." in why and "does not fit the frame" in why
