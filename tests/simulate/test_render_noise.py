"""The sky pixels' one-draw noise has the statistics of the pixel-by-pixel sensor chain."""

import numpy as np
import pytest

from startrack.simulate import _noise as render_noise
from startrack.simulate import _render as render
from startrack.simulate._sensor import SensorModel

_CASES = [  # (electrons, sensor): read noise on and off, a low gain, the ADC floor
    (3.0, SensorModel()),
    (0.4, SensorModel(read_noise=0.0, gain=1.0, bias_adu=50.0)),
    (40.0, SensorModel(gain=2.0, read_noise=3.0, bias_adu=2.0)),
]


def _chain(sensor):
    return (float(sensor.full_well), float(sensor.read_noise), float(sensor.gain),
            float(sensor.bias_adu), float(sensor.adc_max))


def _both_paths(lam, sensor, n, seed):
    """n counts from the sky table and n from the pixel-by-pixel chain, same mean."""
    flat = np.full(n, lam)
    fast = np.empty(n, np.uint16)
    table = render_noise.adu_table(lam, *_chain(sensor))
    others = render._sky_pixels(flat, lam, table, np.random.default_rng(seed), fast)
    assert len(others) == 0
    slow = np.empty(n, np.uint16)
    render._pixel_chain(flat, np.arange(n), render.readout_chain(sensor),
                        np.random.default_rng(seed + 1), slow)
    return fast.astype(np.float64), slow.astype(np.float64)


@pytest.mark.parametrize(("lam", "sensor"), _CASES)
def test_sky_table_matches_the_sensor_chain(lam, sensor):
    n = 1 << 20
    fast, slow = _both_paths(lam, sensor, n, seed=11)
    for a, b in ((fast.mean(), slow.mean()), (fast.var(), slow.var())):
        # two independent samples of 2^20: their means and variances agree within noise
        assert abs(a - b) < 5 * np.sqrt(2 * max(fast.var(), 1e-3) / n) * max(1, np.sqrt(b))
    if sensor.bias_adu > 10 * sensor.read_noise / sensor.gain:  # no ADC floor: analytic
        want_mean = lam / sensor.gain + sensor.bias_adu
        want_var = (lam + sensor.read_noise**2) / sensor.gain**2 \
            + (1 / 12 if sensor.read_noise > 0 else 0.0)
        assert abs(fast.mean() - want_mean) < 5 * np.sqrt(want_var / n)
        assert abs(fast.var() / want_var - 1) < 5 * np.sqrt(2 / n) + 0.002
    # and the whole distribution: a chi-square over the values both drew
    values = np.union1d(fast, slow)
    cf = np.array([np.count_nonzero(fast == v) for v in values], float)
    cs = np.array([np.count_nonzero(slow == v) for v in values], float)
    keep = cf + cs >= 20
    chi2 = (((cf - cs)[keep]) ** 2 / (cf + cs)[keep]).sum()
    dof = max(1, keep.sum() - 1)
    assert chi2 < dof + 6 * np.sqrt(2 * dof)


def test_table_probabilities_are_exact_for_no_read_noise():
    # read noise 0, gain 1: the table is the Poisson CDF itself, shifted by the bias
    from scipy.stats import poisson

    cdf, guide, a0 = render_noise.adu_table(2.5, 1e6, 0.0, 1.0, 10.0, 65535.0)
    assert a0 == 10
    np.testing.assert_allclose(cdf[:20], poisson.cdf(np.arange(20), 2.5), rtol=1e-12)
    assert np.all(np.diff(guide) >= 0)


def test_frame_with_stars_uses_both_paths_deterministically():
    sensor = SensorModel()
    expected = np.full((300, 200), sensor.background_electrons)
    expected[100:110, 50:60] += np.linspace(1, 5000, 100).reshape(10, 10)
    a = render.digitise(expected, sensor, np.random.default_rng(3))
    b = render.digitise(expected, sensor, np.random.default_rng(3))
    np.testing.assert_array_equal(a, b)
    c = render.digitise(expected, sensor, np.random.default_rng(4))
    assert not np.array_equal(a, c)
    star = a[100:110, 50:60].astype(float).ravel()
    mean = expected[100:110, 50:60].ravel() / sensor.gain + sensor.bias_adu
    spread = np.sqrt(expected[100:110, 50:60].ravel() + sensor.read_noise**2) / sensor.gain
    assert np.all(np.abs(star - mean) < 6 * spread)


def test_flat_value_needs_a_majority():
    assert render_noise.flat_value(np.full(1000, 2.0)) == 2.0
    assert render_noise.flat_value(np.linspace(0, 1, 1000)) is None
