"""Exact noise of the sky pixels: one table of the read-out value's distribution per frame.

Most pixels of a star frame expect the same electrons (sky plus dark current). For that
one mean the whole sensor chain (Poisson shot noise, full-well clip, Gaussian read noise,
gain, bias, rounding and ADC clip) maps to one discrete distribution over ADU values,
computed here exactly (Poisson weights times Gaussian bin probabilities) and drawn from
with one uniform per pixel through a guide table. Those pixels get the same distribution
as the pixel-by-pixel chain, at a fraction of the random numbers and work.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import gammaln, ndtr

_TAIL_SIGMA = 9.0  # Gaussian bins this many read-noise sigmas about each count (beyond:
# < 1e-18, below the 2^-53 resolution of a uniform draw)
_MAX_TERMS = 4_000_000  # larger tables (very bright skies) cost more than they save
_GUIDE = 4096  # guide-table buckets: about one step of search per draw


def flat_value(expected: np.ndarray) -> float | None:
    """The mean that most pixels share (sampled), or None when no value dominates."""
    flat = expected.ravel()
    step = max(1, flat.size // 20_000)
    values, counts = np.unique(flat[::step], return_counts=True)
    best = int(np.argmax(counts))
    if counts[best] * 2 < counts.sum() or not math.isfinite(values[best]):
        return None
    return float(values[best])


def adu_table(lam: float, full_well: float, read_noise: float, gain: float, bias: float,
              adc_max: float, nonlinearity: float = 0.0
              ) -> tuple[np.ndarray, np.ndarray, int] | None:
    """CDF over ADU values a0, a0 + 1, ... of a pixel expecting ``lam`` electrons, its
    guide table and a0; None when the table would be too large to pay off.
    ``nonlinearity``: the ADC's compression at full well
    (startrack._core.simulate.render.Readout)."""
    lam = max(lam, 0.0)
    spread = 12.0 * math.sqrt(lam) + 30.0  # Poisson mass beyond: < 1e-30
    k = np.arange(max(0, math.floor(lam - spread)), math.ceil(lam + spread) + 1)
    weight = np.exp(k * math.log(lam) - lam - gammaln(k + 1.0)) if lam > 0 else (k == 0) * 1.0
    e = np.minimum(k, full_well).astype(np.float64)
    if nonlinearity:
        e = e * (1.0 - nonlinearity * e / full_well)
    if read_noise > 0:
        half = math.ceil(_TAIL_SIGMA * read_noise / gain) + 2
        if len(k) * (2 * half + 1) > _MAX_TERMS:
            return None
        centre = np.rint(e / gain + bias)
        a = centre[:, None] + np.arange(-half, half + 1)
        edges = (np.concatenate((a, a[:, -1:] + 1), axis=1) - 0.5 - bias) * gain
        edges[:, 0], edges[:, -1] = -np.inf, np.inf  # the outer bins take the tails
        p = np.diff(ndtr((edges - e[:, None]) / read_noise), axis=1) * weight[:, None]
    else:
        a, p = np.rint(e / gain + bias)[:, None], weight[:, None]
    a = np.clip(a, 0, adc_max).astype(np.int64)
    a0 = int(a.min())
    prob = np.bincount((a - a0).ravel(), weights=p.ravel())
    cdf = np.cumsum(prob) / prob.sum()
    cdf[-1] = np.inf  # every uniform draw (< 1) stops by the last value
    guide = np.searchsorted(cdf, np.arange(_GUIDE) / _GUIDE, side="right")
    return cdf, guide.astype(np.int64), a0
