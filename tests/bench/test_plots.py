"""The comparison plots read: rate axes zoomed to the data, rounding shown as exact, the
held conditions and frame counts named, the heat map whole."""

import numpy as np
import pandas as pd
import pytest

from startrack.bench._conditions import build_conditions
from startrack.bench._plots import (
    ERROR_RESOLUTION_ARCSEC,
    floor_errors,
    held_text,
    plot_sweeps,
    rate_limits,
    wilson,
)

LEVELS = {"noise_px": (0.0, 1.0), "false_stars": (0, 3), "missing": (0.0, 0.2),
          "mag_noise": (0.0,)}


def test_rate_axis_zooms_to_high_rates_and_keeps_the_intervals():
    k, n = np.array([96, 100, 99]), np.array([100, 100, 100])
    low, high = rate_limits(k, n)
    wl, wh = wilson(k, n)
    assert low <= wl.min() and high >= wh.max()
    assert low > 0.8  # 0.96..1.0 fills the axis instead of 0..1
    assert rate_limits([0, 50], [100, 100])[0] < 0.0  # a low rate keeps 0 in view


def test_rounding_errors_are_floored_and_real_errors_kept():
    got = floor_errors([1e-9, 0.5 * ERROR_RESOLUTION_ARCSEC, 0.2, np.nan])
    assert got[0] == 0 and got[1] == 0 and got[2] == 0.2 and np.isnan(got[3])


def test_held_text_names_the_fixed_levels():
    conditions = build_conditions(LEVELS, "full")
    assert held_text(conditions, ("noise_px", "false_stars")) == "held: missing 0"
    text = held_text(conditions, ("missing",))
    assert "noise px 0" in text and "false stars 0" in text and "mag noise" not in text


def _summary(conditions, methods):
    rng = np.random.default_rng(3)
    rows = []
    for k, c in enumerate(conditions):
        for m in methods:
            rate = 1.0 - 0.04 * rng.random()
            rows.append({"condition": k, **c.to_dict(), "method": m, "frames": 50,
                         "correct_rate": rate, "wrong_rate": 0.0, "wrong": 0,
                         "time_median_ms": 0.3, "time_p95_ms": 0.5,
                         "error_median_arcsec": 1e-9 if c.noise_px == 0 else 10.0,
                         "error_p95_arcsec": 2e-9 if c.noise_px == 0 else 30.0})
    return pd.DataFrame(rows)


def test_every_plot_is_written_with_a_heatmap(tmp_path):
    pytest.importorskip("matplotlib")
    import cv2

    conditions = build_conditions(LEVELS, "full")
    methods = ["angle", "pyramid"]
    written = plot_sweeps(_summary(conditions, methods), conditions, methods, tmp_path)
    names = sorted(p.name for p in written)
    assert names == ["heatmap_correct.png", "plot_false_stars.png", "plot_missing.png",
                     "plot_noise_px.png"]
    heat = cv2.imread(str(tmp_path / "heatmap_correct.png"))
    # no empty quarter: the right quarter of the heat map holds drawing, not white
    assert (heat[:, 3 * heat.shape[1] // 4:] < 200).mean() > 0.05


def test_wilson_is_scipys_interval():
    from scipy.stats import binomtest

    k = np.array([0, 1, 17, 96, 99, 100, 5])
    n = np.array([20, 7, 40, 100, 100, 100, 5])
    low, high = wilson(k, n)
    for i in range(len(k)):
        ci = binomtest(int(k[i]), int(n[i])).proportion_ci(0.95, method="wilson")
        assert low[i] == pytest.approx(ci.low, abs=1e-12)
        assert high[i] == pytest.approx(ci.high, abs=1e-12)
