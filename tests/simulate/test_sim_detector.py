"""The simulator's detector: dark current with temperature, PRNU/DSNU maps, blooming,
rolling shutter and ADC non-linearity (docs/simulation.md, the detector rows)."""

import numpy as np
import pytest

from startrack.camera import Camera
from startrack.simulate._detector import Detector
from startrack.simulate._effects import Effects
from startrack.simulate._render import digitise, render_frame
from startrack.simulate._render_effects import expected_with_effects
from startrack.simulate._sensor import SensorModel
from tests.simulate.test_sim_optics import moments, spots

CAM = Camera.from_fov(128, 128, 10.0)


def expected(scene, detector, sensor, rate=None, camera=CAM):
    return expected_with_effects(scene, camera, sensor, Effects(detector=detector),
                                 np.random.default_rng(0), angular_rate_dps=rate)


def test_dark_current_doubles_every_doubling_interval():
    sensor = SensorModel(sky_background=0.0, dark_current=50.0, exposure_s=1.0)
    levels = [expected(spots([[64.0, 64.0]], mag=30.0), Detector(temperature_c=t), sensor)
              for t in (20.0, 26.0, 38.0)]
    np.testing.assert_allclose([lv[0, 0] for lv in levels], [50.0, 100.0, 400.0])
    assert Detector(temperature_c=20.0).dark_factor() == 1.0  # exactly: the default frame
    # in counts: a warmer frame reads brighter by the dark electrons over the gain
    noisy = [render_frame(spots([[64.0, 64.0]], 30.0), CAM, sensor, np.random.default_rng(1),
                          effects=Effects(detector=Detector(temperature_c=t)))
             for t in (20.0, 32.0)]
    rise = np.mean(noisy[1]) - np.mean(noisy[0])
    assert rise == pytest.approx(150.0 / sensor.gain, rel=0.03)


def test_fixed_pattern_maps_are_fixed_by_their_seed():
    a = Detector(prnu=0.02, map_seed=3).prnu_map((64, 64))
    b = Detector(prnu=0.02, map_seed=3).prnu_map((64, 64))
    c = Detector(prnu=0.02, map_seed=4).prnu_map((64, 64))
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)
    assert a.std() == pytest.approx(0.02, rel=0.05) and a.mean() == pytest.approx(1, abs=2e-3)
    dsnu = Detector(dsnu=0.3, map_seed=3).dsnu_map((64, 64))
    assert dsnu.min() >= 0 and dsnu.std() == pytest.approx(0.3, rel=0.05)
    assert Detector().prnu_map((8, 8)) is None and Detector().dsnu_map((8, 8)) is None


def test_prnu_scales_the_photo_signal_and_dsnu_the_dark():
    sensor = SensorModel(sky_background=1000.0, dark_current=0.0, exposure_s=1.0)
    det = Detector(prnu=0.05, map_seed=9)
    image = expected(spots([[64.0, 64.0]], mag=30.0), det, sensor)
    np.testing.assert_allclose(image, 1000.0 * det.prnu_map((128, 128)), rtol=1e-5, atol=1e-6)
    sensor = SensorModel(sky_background=0.0, dark_current=200.0, exposure_s=1.0)
    det = Detector(dsnu=0.5, map_seed=9)
    image = expected(spots([[64.0, 64.0]], mag=30.0), det, sensor)
    np.testing.assert_allclose(image, 200.0 * det.dsnu_map((128, 128)), rtol=1e-5, atol=1e-6)


def test_blooming_spills_charge_along_the_column_only():
    sensor = SensorModel(sky_background=0.0, dark_current=0.0, full_well=30000.0)
    scene = spots([[64.0, 64.0]], mag=-3.0)
    plain = expected(scene, Detector(readout_s=0.0, map_seed=1), sensor)  # no blooming
    bloom = expected(scene, Detector(blooming=True), sensor)
    assert plain.max() > 10 * sensor.full_well
    assert bloom.max() == pytest.approx(sensor.full_well)
    assert bloom.sum() == pytest.approx(plain.sum(), rel=1e-9)  # charge kept on the chip
    column = bloom[:, 64]
    streak = np.flatnonzero(column >= sensor.full_well)
    assert len(streak) > 20 and np.all(np.diff(streak) == 1)  # one run along the column
    rows = np.arange(128)[:, None]
    assert np.all(bloom[np.abs(rows[:, 0] - 64) > 8][:, [50, 78]] < 1.0)  # not sideways


def test_rolling_shutter_shears_a_turning_frame():
    sensor = SensorModel(sky_background=0.0, dark_current=0.0, exposure_s=0.01)
    scene = spots([[64.0, 10.0], [64.0, 118.0]], mag=1.0)
    rate = (0.0, 2.0, 0.0)  # about camera y: stars move along x
    f_px, readout = CAM.f_px, 0.1
    glob = expected(scene, Detector(map_seed=1), sensor, rate)
    roll = expected(scene, Detector(readout_s=readout), sensor, rate)
    shift = [moments(roll, 64, y, half=8)[0] - moments(glob, 64, y, half=8)[0]
             for y in (10.0, 118.0)]
    # rows 10 and 118 are read (118 - 10) / 127 of the read time apart
    sweep = np.radians(2.0) * readout * (118 - 10) / 127 * f_px
    assert abs(shift[1] - shift[0]) == pytest.approx(sweep, rel=0.05)


def test_adc_nonlinearity_compresses_near_full_well():
    sensor = SensorModel(read_noise=0.0, full_well=30000.0, gain=1.0, bias_adu=0.0)
    levels = np.array([[3000.0, 15000.0, 29000.0]] * 1000)
    linear = digitise(levels, sensor, np.random.default_rng(2)).mean(axis=0)
    bent = digitise(levels, sensor, np.random.default_rng(2), nonlinearity=0.05).mean(axis=0)
    want = levels[0] * (1.0 - 0.05 * levels[0] / 30000.0)
    np.testing.assert_allclose(bent, want, rtol=2e-3)
    np.testing.assert_allclose(linear, levels[0], rtol=2e-3)


@pytest.mark.parametrize(("lam", "read_noise"), [
    (0.37, 3.0), (3.0, 3.0), (7.3, 3.0), (25.0, 3.0), (57.6, 3.0),  # Poisson tables
    (127.9, 3.0), (400.0, 3.0),  # tables' last level, PTRS
    (5000.0, 3.0), (0.6, 10.0), (30.7, 10.0), (80.0, 10.0),  # Gaussian: low skewness
])
def test_field_readout_has_the_sensor_chains_statistics(lam, read_noise):
    # a frame whose pixels each expect their own signal goes through the compiled chain
    from startrack.simulate._render_effects import digitise_field

    sensor = SensorModel(read_noise=read_noise, gain=0.5, bias_adu=100.0, full_well=1e5)
    levels = lam * (1.0 + 1e-9 * np.arange(200_000))  # no common value: the field path
    adu = digitise_field(levels, sensor, np.random.default_rng(4)).astype(np.float64)
    e = (adu - 100.0) * 0.5
    # mean: within 4 standard errors (plus the ADU rounding's share)
    error = 4.0 * np.sqrt((lam + read_noise**2) / e.size) + 0.01
    assert e.mean() == pytest.approx(levels.mean(), abs=error)
    # variance: Poisson + read noise + rounding to ADU (gain^2 / 12)
    assert e.var() == pytest.approx(lam + read_noise**2 + 0.25 / 12.0, rel=0.02)


def _direct_stamp(x, y, a, b, c, s, model, half, oversample):
    """A spot's normalised stamp by evaluating its PSF at every sub-sample."""
    from scipy.special import erfc, j1

    size, x0, y0 = 2 * half + 1, int(np.floor(x + 0.5)) - half, int(np.floor(y + 0.5)) - half
    off = (np.arange(oversample) + 0.5) / oversample - 0.5
    dy = (y0 + np.arange(size)[:, None] + off[None, :] - y).ravel()[:, None]
    dx = (x0 + np.arange(size)[:, None] + off[None, :] - x).ravel()[None, :]
    u, v = dx * c + dy * s, -dx * s + dy * c
    if model == 0:
        p = np.exp(-0.5 * ((u / a) ** 2 + (v / b) ** 2))
    elif model == 1:
        z = np.maximum(3.8317059702075125 * np.hypot(u, v) / a, 1e-12)
        p = (2.0 * j1(z) / z) ** 2
    else:
        p = 0.5 * erfc((np.hypot(u, v) - a) / (np.sqrt(2.0) * b))
    p = p.reshape(size, oversample, size, oversample).sum(axis=(1, 3))
    return p / p.sum(), x0, y0


@pytest.mark.parametrize(("model", "a", "b", "c", "s", "half", "oversample"), [
    (0, 2.5, 1.0, 0.6, 0.8, 11, 2), (0, 0.4, 0.3, 1.0, 0.0, 3, 4),
    (0, 0.05, 0.05, 1.0, 0.0, 2, 4), (1, 2.0, 1.0, 1.0, 0.0, 9, 4),
    (2, 1.5, 1.0, 0.6, 0.8, 7, 2), (2, 30.0, 1.0, 1.0, 0.0, 35, 2),
])
def test_compiled_spots_match_their_psf_at_every_sub_sample(model, a, b, c, s, half,
                                                             oversample):
    # the kernel's shortcuts (Gaussian rows by recurrence, round profiles tabulated over
    # the radius) against the PSF evaluated directly
    from startrack._core.simulate import effects as ek

    image, x, y = np.zeros((100, 100)), 50.3, 49.8
    ek.deposit_spots(image, np.array([[x, y, 1000.0, a, b, c, s]]),
                     np.array([model], np.int32), np.array([half]),
                     np.array([oversample], np.int32))
    want, x0, y0 = _direct_stamp(x, y, a, b, c, s, model, half, oversample)
    got = image[y0:y0 + 2 * half + 1, x0:x0 + 2 * half + 1]
    assert image.sum() == pytest.approx(1000.0, rel=1e-12)
    np.testing.assert_allclose(got, 1000.0 * want, atol=1e-5 * 1000.0 * want.max())


@pytest.mark.parametrize("path", ["gaussian", "poisson"])
def test_field_readout_bends_faint_pixels_as_the_chain_does(path):
    # the ADC non-linearity on faint pixels: drawn with the read noise as one Gaussian
    # (read noise 15 e-) or exactly (read noise 1 e-), the mean is lam - b (lam^2 + lam)
    # and the variance lam (1 - 2 b lam)^2 + read noise^2 (to first order in b)
    from startrack.simulate._render_effects import digitise_field

    read_noise, lam, full_well, bend = (15.0 if path == "gaussian" else 1.0), 100.0, 300.0, 0.05
    sensor = SensorModel(read_noise=read_noise, gain=0.5, bias_adu=100.0, full_well=full_well)
    levels = lam * (1.0 + 1e-9 * np.arange(200_000))
    adu = digitise_field(levels, sensor, np.random.default_rng(5), bend).astype(np.float64)
    e, b = (adu - 100.0) * 0.5, bend / full_well
    assert e.mean() == pytest.approx(lam - b * (lam**2 + lam),
                                     abs=4.0 * np.sqrt((lam + read_noise**2) / e.size))
    assert e.var() == pytest.approx(lam * (1 - 2 * b * lam) ** 2 + read_noise**2 + 0.25 / 12,
                                    rel=0.02)
