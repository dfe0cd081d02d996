"""The simulator's optics: PSF models, field-varying aberrations, vignetting, tangential
distortion (docs/simulation.md, the feature table's optics rows)."""

import math

import numpy as np
import pytest

from startrack.attitude import from_radec_roll
from startrack.camera import Camera
from startrack.errors import InputError
from startrack.simulate._effects import Effects, effects_from_dict
from startrack.simulate._optics import COMA_FRACTION, Optics
from startrack.simulate._render import render_frame
from startrack.simulate._render_effects import expected_with_effects
from startrack.simulate._scene import Scene
from startrack.simulate._sensor import SensorModel

CAM = Camera.from_fov(256, 256, 10.0)
DARK = SensorModel(sky_background=0.0, dark_current=0.0)


def spots(xy, mag=3.0):
    xy = np.atleast_2d(np.asarray(xy, dtype=float))
    n = len(xy)
    return Scene(x=xy[:, 0], y=xy[:, 1], mag=np.full(n, mag), catalog_id=np.arange(n),
                 catalog_row=np.arange(n), is_false=np.zeros(n, bool),
                 hot_pixel=np.zeros(n, bool), rotation=from_radec_roll(0.0, 0.0, 0.0))


def expected(scene, optics, sensor=DARK, camera=CAM):
    return expected_with_effects(scene, camera, sensor, Effects(optics=optics),
                                 np.random.default_rng(0))


def moments(image, x, y, half=12):
    r0, c0 = int(round(y)) - half, int(round(x)) - half
    win = image[r0:r0 + 2 * half + 1, c0:c0 + 2 * half + 1]
    rows, cols = np.mgrid[r0:r0 + 2 * half + 1, c0:c0 + 2 * half + 1]
    total = win.sum()
    mx, my = (win * cols).sum() / total, (win * rows).sum() / total
    return mx, my, win


def half_max_width(profile):
    """Full width at half maximum of a sampled 1-D profile (linear interpolation)."""
    peak = profile.argmax()
    half = profile[peak] / 2.0
    left = peak - np.argmax(profile[peak::-1] < half)
    right = peak + np.argmax(profile[peak:] < half)
    fl = left + (half - profile[left]) / (profile[left + 1] - profile[left])
    fr = right - 1 + (profile[right - 1] - half) / (profile[right - 1] - profile[right])
    return fr - fl


def test_effects_off_render_todays_frames():
    scene = spots([[100.3, 90.7], [30.0, 200.2]])
    plain = render_frame(scene, CAM, SensorModel(), np.random.default_rng(5))
    off = render_frame(scene, CAM, SensorModel(), np.random.default_rng(5), effects=Effects())
    np.testing.assert_array_equal(plain, off)


def test_airy_spot_has_the_diffraction_width():
    # FWHM of an Airy pattern: 1.029 lambda N, i.e. 0.8434 of the first dark ring
    optics = Optics(psf="airy", wavelength_nm=700.0, f_number=8.0, pixel_size_um=1.0)
    image = expected(spots([128.0, 128.0], mag=0.0), optics)
    width = half_max_width(image[128, :])
    assert optics.airy_radius_px == pytest.approx(6.832, rel=1e-3)
    assert width == pytest.approx(1.029 * 0.7 * 8.0, rel=0.05)
    # flux is kept: the spot's light sums to the star's electrons
    assert image.sum() == pytest.approx(float(DARK.electrons_from_mag(0.0)), rel=1e-9)


def test_defocus_spot_is_a_flat_disk_of_its_radius():
    optics = Optics(psf="defocus", defocus_radius_px=5.0)
    sensor = SensorModel(sky_background=0.0, dark_current=0.0, psf_sigma_px=0.5)
    image = expected(spots([128.0, 128.0], mag=0.0), optics, sensor)
    row = image[128, :]
    assert half_max_width(row) == pytest.approx(10.0, rel=0.06)
    centre = row[124:133]  # flat top: the centre pixels agree to a few percent
    assert centre.std() / centre.mean() < 0.03


def spread(image, x, y, direction, half=12):
    """Second moment (px^2) of the spot about (x, y) along a unit ``direction``."""
    r0, c0 = int(round(y)) - half, int(round(x)) - half
    win = image[r0:r0 + 2 * half + 1, c0:c0 + 2 * half + 1]
    rows, cols = np.mgrid[r0:r0 + 2 * half + 1, c0:c0 + 2 * half + 1]
    along = (cols - x) * direction[0] + (rows - y) * direction[1]
    return float((win * along**2).sum() / win.sum())


def test_astigmatism_stretches_spots_radially_off_axis():
    optics = Optics(astigmatism=1.0)
    corner, middle = (220.0, 220.0), (127.5, 127.5)
    image = expected(spots([corner, middle], mag=1.0), optics)
    radial, tangential = np.array([1.0, 1.0]) / math.sqrt(2), np.array([1.0, -1.0]) / math.sqrt(2)
    rho = math.hypot(220 - 127.5, 220 - 127.5) / (0.5 * math.hypot(256, 256))
    stretch = (1.0 + rho**2) ** 2  # sigma x (1 + astigmatism rho^2) along the radius
    sigma2 = 1.0 + 1.0 / 12.0  # a unit Gaussian integrated over pixels
    ratio = spread(image, *corner, radial) / spread(image, *corner, tangential)
    assert ratio == pytest.approx((stretch + 1 / 12) / sigma2, rel=0.03)
    centre = spread(image, *middle, radial) / spread(image, *middle, tangential)
    assert centre == pytest.approx(1.0, abs=1e-6)  # round on the axis


def test_coma_biases_centroids_outward_growing_with_field():
    optics = Optics(coma_px=3.0)
    positions = [(127.5 + d, 127.5) for d in (0.0, 60.0, 110.0)]
    image = expected(spots(positions, mag=1.0), optics)
    shifts = [moments(image, x, y)[0] - x for x, y in positions]
    rho = np.array([0.0, 60.0, 110.0]) / (0.5 * math.hypot(256, 256))
    # the tail holds COMA_FRACTION of the light, thrown coma_px rho^3 outward
    np.testing.assert_allclose(shifts, COMA_FRACTION * 3.0 * rho**3, atol=0.02)
    assert shifts[0] == pytest.approx(0.0, abs=1e-4) and shifts[2] > shifts[1] > 0


def test_cos4_vignetting_dims_stars_and_sky_off_axis():
    optics = Optics(vignetting="cos4")
    sensor = SensorModel(dark_current=0.0)
    corner = (250.0, 250.0)
    theta = math.atan(math.hypot(250 - CAM.cx, 250 - CAM.cy) / CAM.f_px)
    image = expected(spots([corner], mag=2.0), optics, sensor)
    sky = sensor.sky_background * sensor.exposure_s
    assert image[0, 0] == pytest.approx(sky * math.cos(math.atan(
        math.hypot(CAM.cx, CAM.cy) / CAM.f_px)) ** 4, rel=1e-5)
    _, _, win = moments(image - 0, *corner, half=5)
    star = win.sum() - image[245:256, 245:256].size * sky * math.cos(theta) ** 4
    assert star == pytest.approx(float(sensor.electrons_from_mag(2.0)) * math.cos(theta) ** 4,
                                 rel=0.02)


def test_measured_vignetting_profile_is_interpolated():
    optics = Optics(vignetting="profile", profile_rho=(0.0, 0.5, 1.0),
                    profile_value=(1.0, 0.8, 0.4))
    half_diag = 0.5 * math.hypot(256, 256)
    x = CAM.cx + np.array([0.0, 0.25, 0.75]) * half_diag
    got = optics.relative_illumination(CAM, x, np.full(3, CAM.cy))
    np.testing.assert_allclose(got, [1.0, 0.9, 0.6])


def test_tangential_distortion_moves_stars_by_brown_conrady():
    optics = Optics(p1=1e-3, p2=-2e-3)
    x, y = np.array([200.0]), np.array([60.0])
    u, v = (x - CAM.cx) / CAM.f_px, (y - CAM.cy) / CAM.f_px
    r2 = u * u + v * v
    xt, yt = optics.tangential(CAM, x, y)
    assert xt[0] - x[0] == pytest.approx(CAM.f_px * (2e-3 * u * v - 2e-3 * (r2 + 2 * u * u))[0])
    assert yt[0] - y[0] == pytest.approx(CAM.f_px * (1e-3 * (r2 + 2 * v * v) - 4e-3 * u * v)[0])
    image = expected(spots([200.0, 60.0], mag=1.0), optics)
    mx, my, _ = moments(image, xt[0], yt[0], half=5)
    assert mx == pytest.approx(xt[0], abs=0.02) and my == pytest.approx(yt[0], abs=0.02)


def test_optics_table_errors_name_the_key():
    with pytest.raises(InputError, match=r"cfg \[optics\]: psf: must be one of"):
        effects_from_dict({"optics": {"psf": "pillbox2"}}, "cfg")
    with pytest.raises(InputError, match=r"cfg \[optics\]: unknown key"):
        effects_from_dict({"optics": {"sigma": 1}}, "cfg")
    with pytest.raises(InputError, match=r"f_number"):
        effects_from_dict({"optics": {"f_number": -1}}, "cfg")
    with pytest.raises(InputError, match=r"profile"):
        effects_from_dict({"optics": {"vignetting": "profile", "profile_rho": [0, 1],
                                      "profile_value": [1.0]}}, "cfg")
