"""The comparison statistics: Wilson and Clopper-Pearson intervals and the exact McNemar
test, held to scipy's binomtest."""

import numpy as np
import pytest
from scipy.stats import binomtest

from startrack.bench._stats import clopper_pearson, format_p, format_rate, mcnemar_exact, wilson


@pytest.mark.parametrize(("k", "n"), [(0, 25), (4, 25), (25, 25), (86, 100), (1, 7)])
def test_intervals_match_scipy(k, n):
    exact = binomtest(k, n).proportion_ci(0.95, method="exact")
    low, high = clopper_pearson(k, n)
    assert low == pytest.approx(exact.low, abs=1e-12)
    assert high == pytest.approx(exact.high, abs=1e-12)
    score = binomtest(k, n).proportion_ci(0.95, method="wilson")
    wl, wh = wilson(k, n)
    assert wl == pytest.approx(score.low, abs=1e-12) and wh == pytest.approx(score.high)


def test_exact_interval_is_wider_than_wilson_for_a_small_count():
    cl, ch = clopper_pearson(0, 25)
    wl, wh = wilson(0, 25)
    assert cl == 0.0 and ch > wh > 0.13
    assert np.isnan(clopper_pearson(0, 0)[0])


def test_format_rate_names_the_counts():
    assert format_rate(4, 25) == "16.0% [6.4, 34.7] (4/25)"
    assert format_rate(0, 0) == "-"


def test_mcnemar_counts_discordant_frames_and_matches_binomtest():
    rng = np.random.default_rng(3)
    a = rng.random(200) < 0.8
    b = a.copy()
    flip = rng.choice(200, 30, replace=False)
    b[flip] = ~b[flip]
    res = mcnemar_exact(a, b)
    assert res.frames == 200 and res.only_a + res.only_b == 30
    assert res.only_a == int(np.sum(a & ~b))
    assert res.p == pytest.approx(binomtest(res.only_a, 30, 0.5).pvalue, rel=1e-12)


def test_mcnemar_extremes():
    same = np.array([True, False, True])
    assert mcnemar_exact(same, same).p == 1.0
    res = mcnemar_exact(np.ones(10, bool), np.zeros(10, bool))
    assert res.only_a == 10 and res.p == pytest.approx(2 * 0.5**10)
    assert format_p(res.p) == "0.002" and format_p(1e-9) == "< 0.0001"
    with pytest.raises(ValueError, match="paired outcomes"):
        mcnemar_exact([True], [True, False])
