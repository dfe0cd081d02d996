"""Statistics a reviewer expects of a comparison: 95% intervals on rates (Wilson score and
Clopper-Pearson exact) and the exact McNemar test for two methods run on the same frames.

Rates in the bench are binomial (k successes over n frames); two methods scored on the
same frames are paired, so their difference is tested on the discordant frames only
(one method right where the other is not), which an unpaired test would ignore.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.stats import beta, binom

#: the two-sided 95% normal quantile, scipy.stats.norm.ppf(0.975) to double precision
Z95 = 1.959963984540054


def wilson(successes, trials, z: float = Z95) -> tuple[np.ndarray, np.ndarray]:
    """Wilson score interval (low, high) of a binomial rate; NaN where trials is 0.

    The same interval as ``scipy.stats.binomtest(k, n).proportion_ci(method="wilson")``
    (tests/bench/test_plots.py holds them equal), kept here because it is vectorised: scipy's
    gives one interval per call (~0.1-1 ms each), this one a whole summary at once.
    """
    k = np.asarray(successes, dtype=np.float64)
    n = np.asarray(trials, dtype=np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        p = k / n
        denom = 1.0 + z * z / n
        centre = (p + z * z / (2 * n)) / denom
        half = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    return np.clip(centre - half, 0.0, 1.0), np.clip(centre + half, 0.0, 1.0)


def clopper_pearson(successes, trials, level: float = 0.95) -> tuple[np.ndarray, np.ndarray]:
    """Clopper-Pearson exact interval (low, high) of a binomial rate; NaN where trials is 0.

    Never narrower than the nominal coverage, so it is the cautious choice for small counts
    (0 of 25 frames wrong still allows up to 13.7%). Equal to
    ``scipy.stats.binomtest(k, n).proportion_ci(level, method="exact")``.
    """
    k = np.asarray(successes, dtype=np.float64)
    n = np.asarray(trials, dtype=np.float64)
    alpha = 1.0 - level
    with np.errstate(invalid="ignore", divide="ignore"):
        low = np.where(k > 0, beta.ppf(alpha / 2, k, n - k + 1), 0.0)
        high = np.where(k < n, beta.ppf(1 - alpha / 2, k + 1, n - k), 1.0)
    bad = ~(n > 0)
    return np.where(bad, np.nan, low), np.where(bad, np.nan, high)


def format_rate(successes: int, trials: int) -> str:
    """"86.0% [77.9, 91.5] (86/100)": the rate, its 95% Wilson interval in percent and
    the counts it comes from; "-" when there are no trials."""
    if trials <= 0:
        return "-"
    low, high = wilson(successes, trials)
    return (f"{successes / trials:.1%} [{100 * float(low):.1f}, {100 * float(high):.1f}] "
            f"({int(successes)}/{int(trials)})")


@dataclass(frozen=True)
class McNemar:
    """The exact McNemar test of two methods on the same frames.

    ``only_a``: frames where A succeeds and B does not; ``only_b`` the reverse; ``both``
    and ``neither`` are the concordant frames (they carry no information on the
    difference); ``p``: two-sided exact p-value (binomial on the discordant frames with
    probability 1/2), 1.0 when there are none.
    """

    only_a: int
    only_b: int
    both: int
    neither: int
    p: float

    @property
    def frames(self) -> int:
        return self.only_a + self.only_b + self.both + self.neither

    def text(self) -> str:
        """"A only 12, B only 3, McNemar exact p = 0.035" (p to two significant digits)."""
        return (f"A only {self.only_a}, B only {self.only_b}, McNemar exact "
                f"p = {format_p(self.p)}")


def format_p(p: float) -> str:
    """A p-value to two significant digits; below 1e-4 as "< 0.0001"."""
    if not np.isfinite(p):
        return "-"
    return "< 0.0001" if p < 1e-4 else f"{p:.2g}"


def mcnemar_exact(a, b) -> McNemar:
    """Exact McNemar test of paired binary outcomes ``a`` and ``b`` (one entry per frame,
    the same frames in the same order, True = success).

    The two-sided p-value is ``min(1, 2 * P(X <= min(only_a, only_b)))`` with ``X`` binomial
    over the discordant frames with probability 1/2, as
    ``scipy.stats.binomtest(only_a, only_a + only_b, 0.5).pvalue`` gives for this
    symmetric case.
    """
    a = np.asarray(a, dtype=bool)
    b = np.asarray(b, dtype=bool)
    if a.shape != b.shape or a.ndim != 1:
        raise ValueError(f"paired outcomes need two 1-d arrays of one length, got shapes "
                         f"{a.shape} and {b.shape}")
    only_a = int(np.sum(a & ~b))
    only_b = int(np.sum(~a & b))
    discordant = only_a + only_b
    p = 1.0 if discordant == 0 else min(
        1.0, 2.0 * float(binom.cdf(min(only_a, only_b), discordant, 0.5)))
    return McNemar(only_a, only_b, int(np.sum(a & b)), int(np.sum(~a & ~b)), p)

__all__ = [
    "McNemar", "Z95", "clopper_pearson", "format_p", "format_rate", "mcnemar_exact", "wilson",
]
