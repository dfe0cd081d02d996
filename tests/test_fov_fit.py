"""The fitted camera (startrack.fov_fit): focal length, and k1 of an undescribed lens."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from startrack.camera import Camera
from startrack.distortion import RadialDistortion
from startrack.fov_fit import LENS_MIN_STARS, fit_camera, fit_focal


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
