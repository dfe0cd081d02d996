"""The dense formulation of the final labelling: observed x catalog tables, as the
labelling computed it before it moved to the pairs within the match radius, in plain
Python and numpy. Kept as the reference that tests/verify/test_labelling_kernels.py holds the
compiled labelling to: numpy's semantics where they decide a result (a median is NaN when
any value is NaN, the best score is the first maximum with NaN counted as the maximum, a
runner-up is NaN when any other score is NaN, a comparison with NaN is False), and the
same errors (Python's: a float division by zero raises, but in the brightness fit, which
divides as numpy does).
"""

from __future__ import annotations

import math

import numpy as np

_MAD_TO_SIGMA = 1.4826
_MEDIAN_R2_TO_SIGMA2 = 1.0 / (2.0 * math.log(2.0))  # Rayleigh: median d^2 = 2 ln2 sigma^2
N_REASONS = 4
_log = math.log  # raises ValueError at or below 0, NaN for NaN


def _median(values: np.ndarray) -> float:
    """numpy's median (NaN for none or any NaN), as a Python float."""
    return float(np.median(values)) if len(values) else math.nan


def _unresolved(x, y, j, resolve2):
    """Whether another catalog star lies within ``sqrt(resolve2)`` of catalog star j: the
    direct scan (the kernel sweeps the catalog once, sorted along x)."""
    hit = False
    for k in range(len(x)):
        dx, dy = x[j] - x[k], y[j] - y[k]
        hit |= (dx * dx + dy * dy < resolve2) & (k != j)
    return hit


def _best_two(score):
    """Per row: the index of the best score (numpy's argmax), the best and the runner-up
    (numpy's max of the rest: NaN if any is NaN; -inf if none)."""
    n, m = score.shape
    best = np.zeros(n, np.int64)
    top = np.full(n, -np.inf)
    nxt = np.full(n, -np.inf)
    for i in range(n):
        if m == 0:
            continue
        b, t = 0, score[i, 0]
        for j in range(1, m):
            if np.isnan(t):
                break
            v = score[i, j]
            if np.isnan(v) or v > t:
                b, t = j, v
        r = -np.inf
        for j in range(m):
            v = score[i, j]
            if j != b and (np.isnan(v) or v > r):
                r = v
        best[i], top[i], nxt[i] = b, t, r
    return best, top, nxt


def _isolated(near):
    """Pairs that are each other's only candidate, in row-major order."""
    n_obs, n_cat = near.shape
    per_obs = np.zeros(n_obs, np.int64)
    per_cat = np.zeros(n_cat, np.int64)
    for i in range(n_obs):
        for j in range(n_cat):
            if near[i, j]:
                per_obs[i] += 1
                per_cat[j] += 1
    oi = np.empty(n_obs, np.int64)
    ci = np.empty(n_obs, np.int64)
    k = 0
    for i in range(n_obs):
        for j in range(n_cat):
            if near[i, j] and per_obs[i] == 1 and per_cat[j] == 1:
                oi[k], ci[k] = i, j
                k += 1
    return oi[:k], ci[:k]


def _brightness(flux, has_flux, near, mag, oi, ci, mag_sigmas, min_mag_sigma, min_fit):
    """Per pair, whether it is consistent in brightness and the log-likelihood ratio of
    its brightness (true star against false star; 0 without a usable flux); the fitted
    scatter and whether brightness is used (not without flux, nor with too few isolated
    pairs with a usable one). Only the ``near`` pairs are evaluated: no other is a
    candidate."""
    n_obs, n_cat = near.shape
    ok = np.ones((n_obs, n_cat), np.bool_)
    log_b = np.zeros((n_obs, n_cat))
    if not has_flux:
        return ok, log_b, np.nan, False
    usable = np.zeros(n_obs, np.bool_)
    inst = np.full(n_obs, np.nan)
    for i in range(n_obs):
        usable[i] = np.isfinite(flux[i]) and flux[i] > 0.0
        if usable[i]:
            inst[i] = -2.5 * math.log10(flux[i])
    keep = np.flatnonzero(usable[oi])
    if len(keep) < min_fit:
        return ok, log_b, np.nan, False
    offset = inst[oi[keep]] - mag[ci[keep]]
    zero = _median(offset)
    sigma = _MAD_TO_SIGMA * _median(np.abs(offset - zero))
    if min_mag_sigma > sigma:
        sigma = min_mag_sigma
    if n_cat == 0:  # as numpy's ptp of nothing
        raise ValueError("zero-size array to reduction operation maximum which has no identity")
    span = np.nan if np.isnan(mag).any() else mag.max() - mag.min()
    if 2.0 * mag_sigmas * sigma > span:
        span = 2.0 * mag_sigmas * sigma
    if span == 0.0:  # as Python's float division
        raise ZeroDivisionError("float division by zero")
    norm = _log(sigma * math.sqrt(2.0 * math.pi) / span)
    limit = mag_sigmas * sigma
    for i in range(n_obs):
        if usable[i]:
            for j in range(n_cat):
                if not near[i, j]:
                    continue
                off = abs(inst[i] - mag[j] - zero)
                ok[i, j] = off <= limit
                with np.errstate(divide="ignore", invalid="ignore"):  # x / 0 as numpy's
                    t = np.float64(off) / np.float64(sigma)
                log_b[i, j] = -0.5 * (t * t) - norm
    return ok, log_b, sigma, True


def _rivals(cand, log_g, gap):
    """Each observed star's best catalog candidate and its score, and whether that pair
    has no rival on either side within the likelihood ``gap``."""
    n_obs, n_cat = cand.shape
    best_c, top_o, next_o = _best_two(log_g)
    # -inf - -inf (no candidate at all) is NaN, and NaN > gap is False.
    with np.errstate(invalid="ignore"):
        clear_o = np.isfinite(top_o) & ~(next_o - top_o > gap)
    score = np.full((n_cat, n_obs), -np.inf)  # per catalog star: its rival observed stars
    for i in range(n_obs):
        for j in range(n_cat):
            # An observed star clearly matched to another catalog star is no rival here.
            if cand[i, j] and not (clear_o[i] and best_c[i] != j):
                score[j, i] = log_g[i, j]
    best_i, top_c, next_c = _best_two(score)
    with np.errstate(invalid="ignore"):
        clear_c = np.isfinite(top_c) & ~(next_c - top_c > gap)
    clear = np.zeros(n_obs, np.bool_)
    if n_cat:
        for i in range(n_obs):
            j = best_c[i]
            clear[i] = clear_o[i] and clear_c[j] and best_i[j] == i
    return best_c, top_o, clear


def _tables(ox, oy, x, y, radius2):
    """Squared distances observed x catalog, and which are within the match radius."""
    d2 = np.empty((len(ox), len(x)))
    for i in range(len(ox)):
        for j in range(len(x)):
            dx, dy = ox[i] - x[j], oy[i] - y[j]
            d2[i, j] = dx * dx + dy * dy
    return d2, d2 <= radius2


def _residual_sigma(d2, oi, ci, sigma0, min_sigma_px, min_fit):
    """The residual scatter per axis: fitted over the isolated pairs when there are enough
    (``sigma0`` otherwise), floored at ``min_sigma_px``."""
    sigma = sigma0
    if len(oi) >= min_fit:
        pair_d2 = np.empty(len(oi))
        for k in range(len(oi)):
            pair_d2[k] = d2[oi[k], ci[k]]
        sigma = math.sqrt(_median(pair_d2) * _MEDIAN_R2_TO_SIGMA2)
    if min_sigma_px > sigma:
        sigma = min_sigma_px
    return float(sigma)


def _coincidence_log(near, area):
    """Log density (per px^2) of a false star on an unobserved catalog star, and the log
    probability that a catalog star is observed, from this frame's own counts (plus one,
    so that a clean frame still allows for one)."""
    n_obs, n_cat = near.shape
    n_false = n_obs - int(np.count_nonzero(near.sum(axis=1)))
    n_unobserved = n_cat - int(np.count_nonzero(near.sum(axis=0)))
    unobserved = (n_unobserved + 1.0) / (n_cat + 2.0)
    return _log((n_false + 1.0) / area * unobserved), _log(1.0 - unobserved)


def label_kernel(ox, oy, x, y, mag, rows, flux, has_flux, radius2, sigma0, area, gap,
                 log_false_odds, resolve2, mag_sigmas, min_mag_sigma, min_sigma_px, min_fit):
    """The final labelling (:func:`startrack.verify._labelling.label_stars`, whose parameters
    these are, the logs and squares taken).

    Returns
    -------
    tuple
        ``obs_index`` (ascending) and ``cat_index`` (from ``rows``) of the reported pairs;
        the withheld counts (:data:`N_REASONS`, in order); the fitted residual scatter;
        the fitted brightness scatter and whether brightness was used.
    """
    n_obs, n_cat = len(ox), len(x)
    d2, near = _tables(ox, oy, x, y, radius2)
    oi, ci = _isolated(near)
    sigma = _residual_sigma(d2, oi, ci, sigma0, min_sigma_px, min_fit)
    bright, log_b, mag_sigma, used = _brightness(flux, has_flux, near, mag, oi, ci,
                                                 mag_sigmas, min_mag_sigma, min_fit)
    cand = near & bright
    log_false, log_seen = _coincidence_log(near, area)
    log_norm = _log(2.0 * math.pi * (sigma * sigma))  # before dividing by sigma^2
    log_g = np.full((n_obs, n_cat), -np.inf)  # residual log-likelihood of the candidates
    for i in range(n_obs):
        for j in range(n_cat):
            if cand[i, j]:
                log_g[i, j] = -float(d2[i, j]) / (2.0 * (sigma * sigma))
    best_c, top, clear = _rivals(cand, log_g, gap)
    withheld = np.zeros(N_REASONS, np.int64)
    ok = np.zeros(n_obs, np.bool_)
    for i in range(n_obs):
        if not near[i].any():
            continue
        log_true = log_seen + top[i] - log_norm
        if n_cat:
            log_true = log_true + log_b[i, best_c[i]]
        if not cand[i].any():
            withheld[0] += 1
        elif n_cat and _unresolved(x, y, best_c[i], resolve2):
            withheld[1] += 1
        elif not clear[i]:
            withheld[2] += 1
        elif not log_false - log_true <= log_false_odds:  # NaN: withheld
            withheld[3] += 1
        else:
            ok[i] = True
    obs_index = np.flatnonzero(ok)
    return obs_index, rows[best_c[obs_index]], withheld, sigma, mag_sigma, used

