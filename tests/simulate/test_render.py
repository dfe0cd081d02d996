"""Scenes and the sensor renderer: PSF position and flux, noise, saturation, blur."""

import numpy as np
import pytest

from startrack.attitude import from_radec_roll
from startrack.camera import Camera
from startrack.simulate._render import render_expected, render_frame, render_stars
from startrack.simulate._scene import Scene, observe
from startrack.simulate._sensor import SensorModel
from startrack.sky import SkySpec, load_sky

CAM = Camera.from_fov(256, 200, 5.0)


def one_spot(x, y, mag, *, false=False, hot=False, camera=CAM):
    rot = from_radec_roll(10.0, 20.0, 0.0)
    arr = np.array
    return Scene(x=arr([x], float), y=arr([y], float), mag=arr([mag], float),
                 catalog_id=arr([-1 if false else 7]), catalog_row=arr([-1 if false else 0]),
                 is_false=arr([false]), hot_pixel=arr([hot]), rotation=rot)


def centroid(image, x, y, half=6):
    r0, c0 = int(round(y)) - half, int(round(x)) - half
    win = image[r0:r0 + 2 * half + 1, c0:c0 + 2 * half + 1].astype(np.float64)
    rows, cols = np.mgrid[r0:r0 + 2 * half + 1, c0:c0 + 2 * half + 1]
    return (win * cols).sum() / win.sum(), (win * rows).sum() / win.sum(), win


@pytest.mark.parametrize("dx,dy", [(0.0, 0.0), (0.25, -0.4), (0.5, 0.1), (-0.33, 0.49)])
def test_noiseless_centroid_is_the_true_position(dx, dy):
    x, y = 100.0 + dx, 80.0 + dy
    cx, cy, _ = centroid(render_stars(one_spot(x, y, 3.0), CAM, SensorModel()), x, y)
    assert abs(cx - x) < 0.05 and abs(cy - y) < 0.05


@pytest.mark.parametrize("dx,dy", [(0.2, 0.3), (-0.45, 0.05)])
def test_noisy_high_signal_centroid(dx, dy):
    sensor = SensorModel(full_well=1e6, gain=20.0)  # bright star, far below saturation
    x, y = 120.0 + dx, 90.0 + dy
    img = render_frame(one_spot(x, y, 0.0), CAM, sensor, np.random.default_rng(3))
    bg = np.median(img)
    cx, cy, _ = centroid(img.astype(np.float64) - bg, x, y)
    assert abs(cx - x) < 0.05 and abs(cy - y) < 0.05


def test_flux_is_conserved():
    sensor = SensorModel()
    for mag, sigma in ((2.0, 1.0), (5.0, 1.7)):
        s = SensorModel(psf_sigma_px=sigma)
        img = render_stars(one_spot(128.3, 99.6, mag), CAM, s)
        assert img.sum() == pytest.approx(float(sensor.electrons_from_mag(mag)), rel=1e-3)
    expected = render_expected(one_spot(50.0, 50.0, 4.0), CAM, sensor)
    background = sensor.background_electrons * CAM.width * CAM.height
    assert expected.sum() == pytest.approx(background + sensor.electrons_from_mag(4.0),
                                           rel=1e-6)


def test_electrons_follow_the_magnitude_law():
    e = SensorModel().electrons_from_mag(np.array([0.0, 2.5, 5.0]))
    np.testing.assert_allclose(e[1:] / e[:-1], 0.1)


def test_same_seed_same_frame_different_seed_different():
    scene = one_spot(60.2, 70.7, 4.0)
    a = render_frame(scene, CAM, SensorModel(), np.random.default_rng(11))
    b = render_frame(scene, CAM, SensorModel(), np.random.default_rng(11))
    c = render_frame(scene, CAM, SensorModel(), np.random.default_rng(12))
    assert a.dtype == np.uint16 and a.shape == (CAM.height, CAM.width)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)


@pytest.mark.parametrize("bits", [16, 12])
def test_saturation_clips_at_adc_max(bits):
    sensor = SensorModel(adc_bits=bits, gain=0.45 if bits == 16 else 7.5)
    img = render_frame(one_spot(100.0, 100.0, -3.0), CAM, sensor, np.random.default_rng(0))
    assert img.max() == 2**bits - 1
    assert (img == 2**bits - 1).sum() >= 5  # a flat saturated core, not one lucky pixel
    faint = render_frame(one_spot(100.0, 100.0, 9.0), CAM, sensor, np.random.default_rng(0))
    assert faint.max() < 2**bits - 1


def test_hot_pixel_is_a_single_pixel_and_blob_is_wide():
    sensor = SensorModel()
    hot = render_stars(one_spot(30.4, 40.6, 3.0, false=True, hot=True), CAM, sensor)
    assert np.count_nonzero(hot) == 1
    assert hot[41, 30] == pytest.approx(float(sensor.electrons_from_mag(3.0)))
    star = render_stars(one_spot(30.0, 40.0, 3.0), CAM, sensor)
    blob = render_stars(one_spot(30.0, 40.0, 3.0, false=True), CAM, sensor)
    assert blob.max() < star.max() / 4  # same flux spread over a wider spot
    assert blob.sum() == pytest.approx(star.sum(), rel=1e-3)


@pytest.fixture(scope="module")
def sky():
    return load_sky(SkySpec(kind="random", n_stars=2000, seed=1, mag_limit=6.5))


def test_observe_projects_catalog_stars(sky):
    cam = Camera.from_fov(1024, 1024, 20.0)
    rot = from_radec_roll(100.0, -30.0, 45.0)
    scene = observe(sky, cam, rot, np.random.default_rng(0))
    assert scene.n_real > 5 and not scene.is_false.any()
    x, y, _ = cam.vector_to_pixel(rot.inv().apply(sky.vectors[scene.catalog_row]))
    np.testing.assert_allclose(scene.x, x)
    np.testing.assert_allclose(scene.y, y)
    np.testing.assert_array_equal(scene.catalog_id, sky.ids[scene.catalog_row])
    assert cam.in_image(scene.x, scene.y).all()
    # A brute-force count over the whole sky agrees with the cone pre-filter.
    xa, ya, front = cam.vector_to_pixel(rot.inv().apply(sky.vectors))
    assert (front & cam.in_image(xa, ya)).sum() == scene.n_real


def test_missing_and_false_stars(sky):
    cam = Camera.from_fov(1024, 1024, 20.0)
    rot = from_radec_roll(100.0, -30.0, 45.0)
    none = observe(sky, cam, rot, np.random.default_rng(0), missing=1.0, false_stars=7)
    assert none.n_real == 0 and len(none) == 7 and none.is_false.all()
    assert (none.catalog_id == -1).all() and cam.in_image(none.x, none.y).all()
    full = observe(sky, cam, rot, np.random.default_rng(0))
    half = observe(sky, cam, rot, np.random.default_rng(0), missing=0.5, mag_noise=0.1)
    assert 0 < half.n_real < full.n_real
    assert set(half.catalog_row) <= set(full.catalog_row)
    lo, hi = full.mag.min(), full.mag.max()
    assert ((none.mag >= lo) & (none.mag <= hi)).all()


@pytest.mark.parametrize("axis", [0, 1])
def test_motion_blur_elongates_along_the_expected_axis(axis):
    cam = Camera.from_fov(256, 256, 5.0)
    sensor = SensorModel()
    rate = [0.0, 0.0, 0.0]
    rate[axis] = 0.3  # deg/s about camera x moves stars along y, about y along x
    x0, y0 = 127.5, 127.5
    sharp = render_stars(one_spot(x0, y0, 3.0, camera=cam), cam, sensor)
    blur = render_stars(one_spot(x0, y0, 3.0, camera=cam), cam, sensor,
                        angular_rate_dps=tuple(rate), blur_steps=16)
    length = np.radians(0.3) * sensor.exposure_s * cam.f_px  # track length in pixels
    cx, cy, win = centroid(blur, x0, y0, half=int(length) + 6)
    half = (win.shape[0] - 1) // 2
    rows, cols = np.mgrid[-half:half + 1, -half:half + 1]
    var_x = (win * (cols + round(x0) - cx) ** 2).sum() / win.sum()
    var_y = (win * (rows + round(y0) - cy) ** 2).sum() / win.sum()
    along, across = (var_y, var_x) if axis == 0 else (var_x, var_y)
    assert across == pytest.approx(sensor.psf_sigma_px**2 + 1 / 12, rel=0.05)
    assert along - across == pytest.approx(length**2 / 12, rel=0.1)
    assert abs(cx - x0) < 0.05 and abs(cy - y0) < 0.05  # the truth is mid-exposure
    assert blur.sum() == pytest.approx(sharp.sum(), rel=1e-3)


@pytest.mark.parametrize("lam", [0.0, 0.3, 3.0, 25.0, 200.0, 2500.0])
def test_shot_noise_has_poisson_mean_and_variance(lam):
    # gain 1, no read noise: counts - bias are the electrons; 2^18 pixels, seeded
    from startrack.simulate._render import digitise

    sensor = SensorModel(gain=1.0, read_noise=0.0, bias_adu=100.0, full_well=1e6)
    counts = digitise(np.full((512, 512), lam), sensor, np.random.default_rng(5))
    e = counts.astype(np.float64) - 100.0
    n = e.size
    assert abs(e.mean() - lam) < 5 * np.sqrt(max(lam, 1e-3) / n) + 1e-9
    # the variance of a sample variance is ~ (mu4 - sigma^4) / n = (lam + 2 lam^2) / n
    assert abs(e.var() - lam) < 5 * np.sqrt((lam + 2 * lam**2) / n) + 1e-9
    if lam < 1000:  # exact Poisson: integer counts, P(0) = exp(-lam)
        assert abs(np.mean(e == 0) - np.exp(-lam)) < 5 * np.sqrt(np.exp(-lam) / n) + 1e-9


def test_read_noise_and_gain_add_up():
    from startrack.simulate._render import digitise

    sensor = SensorModel(gain=0.5, read_noise=10.0, bias_adu=300.0)
    lam = np.where(np.arange(512)[:, None] % 2 == 0, 4.0, 1500.0) * np.ones((512, 512))
    counts = digitise(lam, sensor, np.random.default_rng(6)).astype(np.float64)
    for value in (4.0, 1500.0):
        sel = counts[lam == value]
        assert abs(sel.mean() - (value / 0.5 + 300.0)) < 0.5
        # variance in ADU: (shot + read^2) / gain^2 plus 1/12 of rounding
        want = (value + 100.0) / 0.25 + 1 / 12
        assert abs(sel.var() / want - 1) < 0.03


def test_digitise_is_reproducible_with_a_seed():
    from startrack.simulate._render import digitise

    lam = np.linspace(0, 5000, 64 * 64).reshape(64, 64)
    a = digitise(lam, SensorModel(), np.random.default_rng(9))
    b = digitise(lam, SensorModel(), np.random.default_rng(9))
    np.testing.assert_array_equal(a, b)
