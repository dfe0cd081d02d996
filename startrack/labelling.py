"""Final labelling: which observed star is reported as which catalog star, once the attitude
is accepted; one-to-one, and a star is left unidentified rather than guessed.

Verification decides whether the attitude is right; this module decides which identities
are certain enough to report at that attitude. The catalog stars are projected into the
image; every observed star within the match radius of one is a candidate. A candidate
pair is reported only when all of these hold:

* brightness: when the stars carry a flux, the zero point of ``-2.5 log10(flux)`` against
  the catalog magnitude is fitted over the isolated pairs (one candidate each way), with
  its robust scatter; a candidate whose magnitude is off by more than ``mag_sigmas`` times
  that scatter is no candidate (a false star, or the wrong star of a close pair);
* resolution: no other catalog star lies within ``resolve_px`` of the catalog star (the
  optics see one spot; which star it is would be a coin toss);
* no rival: the observed star's next catalog candidate, and the catalog star's next
  observed candidate (one not clearly matched elsewhere), are at least ``1/ambiguity``
  times less likely by their residuals, with the residual scatter fitted over the
  isolated pairs;
* not a coincidence: a false star landing that close to an unobserved catalog star (the
  false-star density and the unobserved fraction measured in this frame; its brightness
  uniform over the catalog magnitudes in view) is at most ``false_odds`` times as likely
  as the true star at that residual and brightness. This is what keeps out a residual
  far beyond the other matches' scatter.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from startrack.types import Observation

#: Catalog stars closer than this many pixels are one spot (as startrack.sky merges them).
RESOLVE_PX = 2.0
_MAD_TO_SIGMA = 1.4826
_MEDIAN_R2_TO_SIGMA2 = 1.0 / (2.0 * math.log(2.0))  # Rayleigh: median d^2 = 2 ln2 sigma^2


@dataclass(frozen=True)
class LabelConfig:
    """Thresholds of the final labelling (see the module docstring)."""

    ambiguity: float = 1e-3
    false_odds: float = 1e-3
    resolve_px: float = RESOLVE_PX
    mag_sigmas: float = 5.0
    min_mag_sigma: float = 0.03  # mag: the floor of the fitted brightness scatter
    min_sigma_px: float = 0.02  # px: the floor of the fitted residual scatter
    min_fit: int = 5  # isolated pairs needed to fit the scatters


@dataclass(frozen=True)
class Labelling:
    """The reported identities (``obs_index`` ascending, ``cat_index`` catalog rows) and
    how many observed stars with a candidate were left unidentified, by reason."""

    obs_index: np.ndarray
    cat_index: np.ndarray
    withheld: dict[str, int] = field(default_factory=dict)
    sigma_px: float = float("nan")  # fitted residual scatter per axis
    mag_sigma: float | None = None  # fitted brightness scatter; None: not used


def _isolated(cand: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pairs that are each other's only candidate."""
    one = cand & (cand.sum(axis=1, keepdims=True) == 1) & (cand.sum(axis=0, keepdims=True) == 1)
    return np.nonzero(one)


def _brightness(obs: Observation, mag: np.ndarray, cand: np.ndarray,
                pairs: tuple[np.ndarray, np.ndarray],
                config: LabelConfig) -> tuple[np.ndarray, np.ndarray, float | None]:
    """Candidates consistent in brightness (all of them without usable fluxes); per pair,
    the log-likelihood ratio of its brightness for the true star (Gaussian about the
    fitted zero point) against a false star (uniform over the catalog magnitudes in view;
    0 without a usable flux); the fitted scatter (None when brightness is not used)."""
    none = (np.ones_like(cand), np.zeros(cand.shape), None)
    if obs.flux is None:
        return none
    flux = np.asarray(obs.flux, dtype=np.float64)
    usable = np.isfinite(flux) & (flux > 0)
    inst = np.where(usable, -2.5 * np.log10(np.where(usable, flux, 1.0)), np.nan)
    oi, ci = pairs
    keep = usable[oi]
    if np.count_nonzero(keep) < config.min_fit:
        return none
    offset = inst[oi[keep]] - mag[ci[keep]]
    zero = float(np.median(offset))
    sigma = max(_MAD_TO_SIGMA * float(np.median(np.abs(offset - zero))), config.min_mag_sigma)
    off = np.abs(inst[:, None] - mag[None, :] - zero)
    ok = ~usable[:, None] | (off <= config.mag_sigmas * sigma)
    span = max(float(np.ptp(mag)), 2.0 * config.mag_sigmas * sigma)
    log_ratio = -0.5 * (off / sigma) ** 2 - math.log(sigma * math.sqrt(2.0 * math.pi) / span)
    return ok, np.where(usable[:, None], log_ratio, 0.0), sigma


def _best_two(score: np.ndarray, axis: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Index of the best score along ``axis``, the best and the runner-up (-inf if none)."""
    if score.shape[axis] == 0:
        n = score.shape[1 - axis]
        return np.zeros(n, np.int64), np.full(n, -np.inf), np.full(n, -np.inf)
    best = np.argmax(score, axis=axis)
    top = np.take_along_axis(score, np.expand_dims(best, axis), axis).squeeze(axis)
    rest = score.copy()
    np.put_along_axis(rest, np.expand_dims(best, axis), -np.inf, axis)
    return best, top, rest.max(axis=axis)


def _rivals(cand: np.ndarray, log_g: np.ndarray,
            gap: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each observed star's best catalog candidate, and whether that pair has no rival on
    either side within the likelihood ``gap`` (log of the ambiguity ratio)."""
    n_obs, n_cat = cand.shape
    best_c, top_o, next_o = _best_two(log_g, axis=1)
    with np.errstate(invalid="ignore"):  # -inf - -inf: no candidate at all
        clear_o = np.isfinite(top_o) & ~(next_o - top_o > gap)
    # An observed star clearly matched to another catalog star is no rival for this one.
    rival = cand & ~(clear_o[:, None] & (best_c[:, None] != np.arange(n_cat)[None, :]))
    best_i, top_c, next_c = _best_two(np.where(rival, log_g, -np.inf), axis=0)
    with np.errstate(invalid="ignore"):
        clear_c = np.isfinite(top_c) & ~(next_c - top_c > gap)
    mutual = np.zeros(n_obs, bool)
    if n_cat:
        mutual = clear_c[best_c] & (best_i[best_c] == np.arange(n_obs))
    return best_c, top_o, clear_o & mutual


def _coincidence_log(obs: Observation, near: np.ndarray) -> tuple[float, float]:
    """Log density (per px^2) of a false star on an unobserved catalog star, and the log
    probability that a catalog star is observed, both from this frame's own counts (plus
    one, so that a clean frame still allows for one)."""
    area = float(obs.camera.width * obs.camera.height)
    n_false = int(np.count_nonzero(~near.any(axis=1)))
    n_unobserved = int(np.count_nonzero(~near.any(axis=0)))
    unobserved = (n_unobserved + 1.0) / (near.shape[1] + 2.0)
    return math.log((n_false + 1.0) / area * unobserved), math.log(1.0 - unobserved)


def _unresolved(x: np.ndarray, y: np.ndarray, resolve_px: float) -> np.ndarray:
    """Catalog stars with another catalog star within ``resolve_px``."""
    if len(x) < 2:
        return np.zeros(len(x), bool)
    sep2 = (x[:, None] - x[None, :]) ** 2 + (y[:, None] - y[None, :]) ** 2
    np.fill_diagonal(sep2, np.inf)
    return np.any(sep2 < resolve_px**2, axis=1)


def label_stars(obs: Observation, rows: np.ndarray, x: np.ndarray, y: np.ndarray,
                mag: np.ndarray, radius_px: float,
                config: LabelConfig | None = None) -> Labelling:
    """Report each observed star as a catalog star only where nothing else is plausible.

    Parameters
    ----------
    obs : Observation
        The frame's observed stars (``flux`` optional).
    rows, x, y, mag : numpy.ndarray
        The catalog stars projected at the accepted attitude: catalog rows, pixel
        positions and catalog magnitudes.
    radius_px : float
        The match radius of verification, in pixels.
    config : LabelConfig, optional
        Thresholds; the defaults when None.

    Returns
    -------
    Labelling
        One-to-one identities, and the count of withheld stars per reason
        (``brightness``, ``unresolved``, ``ambiguous``, ``coincidence``).
    """
    config = config or LabelConfig()
    rows = np.asarray(rows, dtype=np.int64)
    x, y, mag = (np.asarray(a, dtype=np.float64) for a in (x, y, mag))
    d2 = (obs.x[:, None] - x[None, :]) ** 2 + (obs.y[:, None] - y[None, :]) ** 2
    near = d2 <= radius_px**2
    pairs = _isolated(near)
    sigma = obs.sigma_rad * obs.camera.f_px
    if len(pairs[0]) >= config.min_fit:
        sigma = math.sqrt(float(np.median(d2[pairs])) * _MEDIAN_R2_TO_SIGMA2)
    sigma = max(sigma, config.min_sigma_px)
    bright, log_b, mag_sigma = _brightness(obs, mag, near, pairs, config)
    cand = near & bright
    log_g = np.where(cand, -d2 / (2.0 * sigma**2), -np.inf)  # residual log-likelihood
    best_c, top, clear = _rivals(cand, log_g, math.log(config.ambiguity))
    log_false, log_seen = _coincidence_log(obs, near)
    log_true = log_seen + top - math.log(2.0 * math.pi * sigma**2)
    if len(rows):
        log_true = log_true + log_b[np.arange(len(obs)), best_c]
    has = near.any(axis=1)
    with np.errstate(invalid="ignore"):
        coincidence = ~(log_false - log_true <= math.log(config.false_odds))
    reasons = {
        "brightness": has & ~cand.any(axis=1),
        "unresolved": _unresolved(x, y, config.resolve_px)[best_c] if len(rows)
        else np.zeros(len(obs), bool),
        "ambiguous": ~clear,
        "coincidence": coincidence,
    }
    ok = has.copy()
    withheld = {}
    for name, bad in reasons.items():
        withheld[name] = int(np.count_nonzero(ok & bad))
        ok &= ~bad
    obs_index = np.flatnonzero(ok)
    return Labelling(obs_index, rows[best_c[obs_index]], withheld, sigma, mag_sigma)
