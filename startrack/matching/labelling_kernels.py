"""Compiled kernel of the final labelling (startrack.verify._labelling): one call per accepted
attitude, over the observed-catalog pairs within the match radius only.

:func:`label_kernel` is the implementation of :func:`startrack.verify._labelling.label_stars`; the
rules are described there. A frame pairs each observed star with about one catalog star,
so the kernel finds those pairs once
(:func:`startrack.matching.nearest_kernels.pairs_within`) and works on that list instead
of dense observed x catalog tables, whose cost grew with the product of the two counts.
Its results are those of the dense formulation, which the tests keep as the reference
(``tests/labelling_dense_reference.py``): numpy's semantics decide where they matter (a
median is NaN when any value is NaN, the best score is the first maximum with NaN counted
as the maximum, a comparison with NaN is False), and the same ``ValueError`` /
``ZeroDivisionError`` is raised where numpy's version raised.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from startrack.matching.nearest_kernels import pairs_within
from startrack.matching.stats_kernels import median as _median
from startrack.matching.stats_kernels import ptp as _span

_MAD_TO_SIGMA = 1.4826
_MEDIAN_R2_TO_SIGMA2 = 1.0 / (2.0 * math.log(2.0))  # Rayleigh: median d^2 = 2 ln2 sigma^2
#: The order of :data:`withheld`'s counts: brightness, unresolved, ambiguous, coincidence.
N_REASONS = 4


@njit(cache=True)
def _log(value):
    """math.log, raising where Python's does (numba's gives -inf or NaN)."""
    if value <= 0.0:
        raise ValueError("math domain error")
    return math.log(value)


@njit(cache=True)
def _best_two(values, group_start, order):
    """Per group (its entries ``order[group_start[g]:group_start[g + 1]]``, in that
    order, every other entry of the dense row being -inf): the index entry of the best
    value (numpy's argmax: the first maximum, NaN counted as the maximum; -1 when the row
    is all -inf), the best and the runner-up (numpy's max of the rest: NaN if any is NaN)."""
    g_n = group_start.shape[0] - 1
    best = np.full(g_n, -1, np.int64)
    top = np.full(g_n, -np.inf)
    nxt = np.full(g_n, -np.inf)
    for g in range(g_n):
        b, t = -1, -np.inf
        for s in range(group_start[g], group_start[g + 1]):
            if np.isnan(t):
                break
            v = values[order[s]]
            if np.isnan(v) or v > t:
                b, t = order[s], v
        r = -np.inf
        for s in range(group_start[g], group_start[g + 1]):
            v = values[order[s]]
            if order[s] != b and (np.isnan(v) or v > r):
                r = v
        best[g], top[g], nxt[g] = b, t, r
    return best, top, nxt


@njit(cache=True, error_model="numpy")  # x / 0 is inf or NaN, as numpy's
def _brightness(flux, has_flux, e_obs, e_cat, mag, oi, ci, mag_sigmas, min_mag_sigma,
                min_fit):
    """Per pair, whether it is consistent in brightness and the log-likelihood ratio of
    its brightness (true star against false star; 0 without a usable flux); the fitted
    scatter and whether brightness is used (not without flux, nor with too few isolated
    pairs with a usable one)."""
    n_pairs = e_obs.shape[0]
    ok = np.ones(n_pairs, np.bool_)
    log_b = np.zeros(n_pairs)
    if not has_flux:
        return ok, log_b, np.nan, False
    n_obs = flux.shape[0]
    usable = np.zeros(n_obs, np.bool_)
    inst = np.full(n_obs, np.nan)
    for i in range(n_obs):
        usable[i] = np.isfinite(flux[i]) and flux[i] > 0.0
        if usable[i]:
            inst[i] = -2.5 * math.log10(flux[i])
    offset = np.empty(oi.shape[0])
    n_fit = 0
    for k in range(oi.shape[0]):
        if usable[oi[k]]:
            offset[n_fit] = inst[oi[k]] - mag[ci[k]]
            n_fit += 1
    if n_fit < min_fit:
        return ok, log_b, np.nan, False
    offset = offset[:n_fit]
    zero = _median(offset)
    for k in range(n_fit):
        offset[k] = abs(offset[k] - zero)
    sigma = _MAD_TO_SIGMA * _median(offset)
    if min_mag_sigma > sigma:
        sigma = min_mag_sigma
    if mag.shape[0] == 0:  # as numpy's ptp of nothing
        raise ValueError("zero-size array to reduction operation maximum which has no identity")
    span = _span(mag)
    if 2.0 * mag_sigmas * sigma > span:
        span = 2.0 * mag_sigmas * sigma
    if span == 0.0:  # as Python's float division
        raise ZeroDivisionError("float division by zero")
    norm = _log(sigma * math.sqrt(2.0 * math.pi) / span)
    limit = mag_sigmas * sigma
    for k in range(n_pairs):
        i = e_obs[k]
        if usable[i]:
            off = abs(inst[i] - mag[e_cat[k]] - zero)
            ok[k] = off <= limit
            t = off / sigma
            log_b[k] = -0.5 * (t * t) - norm
    return ok, log_b, sigma, True


@njit(cache=True)
def _isolated(e_obs, e_cat, start, per_cat):
    """The pairs that are each other's only candidate, by observed index: (obs, cat, pair)."""
    n = start.shape[0] - 1
    oi = np.empty(n, np.int64)
    ci = np.empty(n, np.int64)
    pk = np.empty(n, np.int64)
    k = 0
    for i in range(n):
        if start[i + 1] - start[i] == 1 and per_cat[e_cat[start[i]]] == 1:
            oi[k], ci[k], pk[k] = i, e_cat[start[i]], start[i]
            k += 1
    return oi[:k], ci[:k], pk[:k]


@njit(cache=True)
def _residual_sigma(e_d2, pk, sigma0, min_sigma_px, min_fit):
    """The residual scatter per axis: fitted over the isolated pairs when there are enough
    (``sigma0`` otherwise), floored at ``min_sigma_px``."""
    sigma = sigma0
    if len(pk) >= min_fit:
        sigma = math.sqrt(_median(e_d2[pk]) * _MEDIAN_R2_TO_SIGMA2)
    if min_sigma_px > sigma:
        sigma = min_sigma_px
    return sigma


@njit(cache=True)
def _rivals(e_obs, e_cat, start, cand, log_g, gap, n_cat):
    """Each observed star's best catalog candidate (-1: none) and its score, and whether
    that pair has no rival on either side within the likelihood ``gap``."""
    n_obs = start.shape[0] - 1
    n_pairs = e_obs.shape[0]
    best_o, top_o, next_o = _best_two(log_g, start, np.arange(n_pairs))
    # -inf - -inf (no candidate at all) is NaN, and NaN > gap is False.
    clear_o = np.isfinite(top_o) & ~(next_o - top_o > gap)
    rival = np.full(n_pairs, -np.inf)  # per catalog star: its rival observed stars
    for k in range(n_pairs):
        i = e_obs[k]
        # An observed star clearly matched to another catalog star is no rival here.
        if cand[k] and not (clear_o[i] and best_o[i] != k):
            rival[k] = log_g[k]
    cat_start = np.zeros(n_cat + 1, np.int64)
    for k in range(n_pairs):
        cat_start[e_cat[k] + 1] += 1
    for j in range(n_cat):
        cat_start[j + 1] += cat_start[j]
    # By catalog then observed index: a counting sort of the pairs, which come by
    # observed index, is that order (each pair is unique, so any sort agrees).
    by_cat = np.empty(n_pairs, np.int64)
    fill = cat_start[:-1].copy()
    for k in range(n_pairs):
        by_cat[fill[e_cat[k]]] = k
        fill[e_cat[k]] += 1
    best_c, top_c, next_c = _best_two(rival, cat_start, by_cat)
    clear_c = np.isfinite(top_c) & ~(next_c - top_c > gap)
    clear = np.zeros(n_obs, np.bool_)
    for i in range(n_obs):
        k = best_o[i]
        if k >= 0:
            j = e_cat[k]
            clear[i] = clear_o[i] and clear_c[j] and best_c[j] == k
    return best_o, top_o, clear


@njit(cache=True)
def _crowded(x, y, resolve2):
    """Per catalog star, whether another lies closer than ``sqrt(resolve2)`` (squared
    distance below ``resolve2``; NaN is no neighbour): a sweep along x, in x order, that
    stops where the x gap alone reaches the limit, so a frame costs O(m log m) and not
    O(n m)."""
    m = x.shape[0]
    crowded = np.zeros(m, np.bool_)
    if not resolve2 > 0.0:
        return crowded  # no squared distance is below it
    order = np.argsort(x)
    for a in range(m):
        i = order[a]
        for b in range(a + 1, m):
            j = order[b]
            gap = x[j] - x[i]
            # Later stars are farther along x, and dy^2 only adds: none is closer.
            if gap * gap >= resolve2:
                break
            dx, dy = x[i] - x[j], y[i] - y[j]
            if dx * dx + dy * dy < resolve2:
                crowded[i] = crowded[j] = True
    return crowded


@njit(cache=True)
def _coincidence_log(start, per_cat, area):
    """Log density (per px^2) of a false star on an unobserved catalog star, and the log
    probability that a catalog star is observed, from this frame's own counts (plus one,
    so that a clean frame still allows for one)."""
    n_obs, n_cat = start.shape[0] - 1, per_cat.shape[0]
    n_false = n_obs - int(np.count_nonzero(start[1:] - start[:-1]))
    n_unobserved = n_cat - int(np.count_nonzero(per_cat))
    unobserved = (n_unobserved + 1.0) / (n_cat + 2.0)
    return _log((n_false + 1.0) / area * unobserved), _log(1.0 - unobserved)


@njit(cache=True)
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
    e_obs, e_cat, e_d2, start = pairs_within(ox, oy, x, y, radius2)
    per_cat = np.zeros(n_cat, np.int64)
    for k in range(e_cat.shape[0]):
        per_cat[e_cat[k]] += 1
    oi, ci, pk = _isolated(e_obs, e_cat, start, per_cat)
    sigma = _residual_sigma(e_d2, pk, sigma0, min_sigma_px, min_fit)
    cand, log_b, mag_sigma, used = _brightness(flux, has_flux, e_obs, e_cat, mag, oi, ci,
                                               mag_sigmas, min_mag_sigma, min_fit)
    log_false, log_seen = _coincidence_log(start, per_cat, area)
    log_norm = _log(2.0 * math.pi * (sigma * sigma))  # before dividing by sigma^2
    log_g = np.full(e_obs.shape[0], -np.inf)  # residual log-likelihood of the candidates
    for k in range(e_obs.shape[0]):
        if cand[k]:
            log_g[k] = -e_d2[k] / (2.0 * (sigma * sigma))
    best, top, clear = _rivals(e_obs, e_cat, start, cand, log_g, gap, n_cat)
    crowded = _crowded(x, y, resolve2)
    withheld = np.zeros(N_REASONS, np.int64)
    ok = np.zeros(n_obs, np.bool_)
    best_cat = np.zeros(n_obs, np.int64)  # numpy's argmax of an all -inf row: 0
    for i in range(n_obs):
        if start[i + 1] == start[i]:
            continue
        k = best[i]
        log_true = log_seen + top[i] - log_norm
        if k >= 0:
            best_cat[i] = e_cat[k]
            log_true = log_true + log_b[k]
        else:
            log_true = log_true + _log_b_at(e_cat, log_b, start[i], start[i + 1], 0)
        if not cand[start[i]:start[i + 1]].any():
            withheld[0] += 1
        elif n_cat and crowded[best_cat[i]]:
            withheld[1] += 1
        elif not clear[i]:
            withheld[2] += 1
        elif not log_false - log_true <= log_false_odds:  # NaN: withheld
            withheld[3] += 1
        else:
            ok[i] = True
    obs_index = np.flatnonzero(ok)
    return obs_index, rows[best_cat[obs_index]], withheld, sigma, mag_sigma, used


@njit(cache=True)
def _log_b_at(e_cat, log_b, lo, hi, j):
    """The brightness term of the pair with catalog star ``j`` among pairs lo:hi, 0 if
    there is none (the dense table's value)."""
    for k in range(lo, hi):
        if e_cat[k] == j:
            return log_b[k]
    return 0.0


def warm_up() -> None:
    """Compile (or load from numba's cache) :func:`label_kernel` with the argument types
    :func:`startrack.verify._labelling.label_stars` passes, so that no timed frame compiles it."""
    v = np.array([10.0, 40.0, 70.0, 100.0, 130.0, 160.0])
    label_kernel(v, v, v, v, v / 30.0, np.arange(len(v), dtype=np.int64), v, True, 16.0, 1.0,
                 1e4, math.log(1e-3), math.log(1e-3), 4.0, 5.0, 0.03, 0.02, 5)
