"""The final labelling (:func:`startrack.verify.label_stars`, whose rules it
implements): one call per accepted attitude, over the observed-catalog pairs within the
match radius only, found on one grid with the catalog stars too close to resolve
(:func:`startrack._core.verify.nearest.pairs_and_crowded`).

Its results are those of the dense observed x catalog formulation, which the tests keep
as the reference (``tests/verify/labelling_dense_reference.py``): numpy's semantics decide where
they matter (a median is NaN when any value is NaN, the best score is the first maximum
with NaN counted as the maximum, a comparison with NaN is False), and the same
``ValueError`` / ``ZeroDivisionError`` is raised where numpy's version raised.
"""

cimport cython
import threading

import numpy as np

from libc.math cimport INFINITY, M_PI, NAN, fabs, isfinite, isnan, log, log10, sqrt

cimport numpy as cnp
from startrack._core._arrays cimport (empty_i64, room_f64, room_i64, room_u8)
from startrack._core.verify.nearest cimport NearestScratch, Pairs, pairs_and_crowded
from startrack._core._stats cimport median_inplace, ptp

cdef double _MAD_TO_SIGMA = 1.4826
cdef double _MEDIAN_R2_TO_SIGMA2 = 1.0 / (2.0 * log(2.0))  # Rayleigh: median d^2 = 2 ln2 s^2

cnp.import_array()  # the C API the _arrays helpers call


cdef class Labels:
    def __iter__(self):
        """(obs, cat, withheld, sigma_px, mag_sigma, used), as the Python callers take it."""
        return iter((np.asarray(self.obs), np.asarray(self.cat),
                     np.array(self.withheld, np.int64),
                     self.sigma_px, self.mag_sigma, self.used))


cdef class _Work:
    """The labelling's working arrays (per catalog star, observed star or pair), kept
    from one call to the next: allocating them costs more than labelling tens of stars.
    Lengths only grow; a call sets every value it reads."""
    cdef long long[::1] per_cat, cat_start, fill, iso, best, by_cat, lab_obs, lab_cat
    cdef double[::1] inst, top, log_b, log_g, rival, offset, d2
    cdef unsigned char[::1] clear_o, clear, ok, crowded


# Per thread, as a call may let another thread run (a finalizer's bytecode).
_THREAD = threading.local()


cdef _Work _thread_work():
    cdef _Work work = getattr(_THREAD, "work", None)
    if work is None:
        work = _THREAD.work = _Work.__new__(_Work)
    return work


cdef inline long long[::1] _set_i64(long long[::1] held, Py_ssize_t n, long long value):
    """The first ``n`` values of a held buffer (room_i64 made room), each set to ``value``."""
    cdef long long[::1] out = held[:n]
    out[:] = value
    return out


cdef inline double[::1] _set_f64(double[::1] held, Py_ssize_t n, double value):
    cdef double[::1] out = held[:n]
    out[:] = value
    return out


cdef inline unsigned char[::1] _set_u8(unsigned char[::1] held, Py_ssize_t n,
                                       unsigned char value):
    cdef unsigned char[::1] out = held[:n]
    out[:] = value
    return out


cdef double _log(double value) except? -1.0:  # log, raising where Python's math.log does
    if value <= 0.0:
        raise ValueError("math domain error")
    return log(value)


cdef struct Best:
    Py_ssize_t index   # the entry of the best value (-1: none)
    double top         # the best value
    double runner_up   # the best of the rest


cdef struct _Logs:
    double false_star  # log density of a false star on an unobserved catalog star
    double seen        # log probability that a catalog star is observed
    double norm        # log normalisation of the residual density
    double odds        # the log odds allowed
    double sigma       # the fitted residual scatter


cdef Best _best_two(const double[::1] values, Py_ssize_t lo, Py_ssize_t hi,
                    const long long* order) noexcept:
    """Over the entries ``order[lo:hi]`` (NULL: lo:hi themselves) of a dense row whose
    others are -inf: numpy's argmax (the first maximum, NaN counted as the maximum; -1
    when all are -inf), the best and numpy's max of the rest (NaN if any is NaN)."""
    cdef Best out
    cdef Py_ssize_t s, e
    cdef double v
    out.index, out.top, out.runner_up = -1, -INFINITY, -INFINITY
    for s in range(lo, hi):
        if isnan(out.top):
            break
        e = s if order == NULL else order[s]
        v = values[e]
        if isnan(v) or v > out.top:
            out.index, out.top = e, v
    for s in range(lo, hi):
        e = s if order == NULL else order[s]
        v = values[e]
        if e != out.index and (isnan(v) or v > out.runner_up):
            out.runner_up = v
    return out


include "labelling_fit.pxi"


cdef inline bint _clear(Best b, double gap) noexcept:
    # -inf - -inf (no candidate at all) is NaN, and NaN > gap is False.
    return isfinite(b.top) and not (b.runner_up - b.top > gap)


cdef unsigned char[::1] _rivals(Pairs pairs, const unsigned char[::1] cand,
                                const double[::1] log_g, double gap, Py_ssize_t n_cat,
                                long long[::1] best_pair, double[::1] top, _Work w):
    """Each observed star's best candidate pair (-1: none) and its score, written into
    ``best_pair`` and ``top``; returns whether that pair has no rival on either side
    within the likelihood ``gap``."""
    cdef Py_ssize_t n_obs = pairs.start.shape[0] - 1, n_pairs = pairs.obs.shape[0]
    cdef Py_ssize_t i, j, k
    w.clear_o, w.clear = room_u8(w.clear_o, n_obs), room_u8(w.clear, n_obs)
    w.rival, w.by_cat = room_f64(w.rival, n_pairs), room_i64(w.by_cat, n_pairs)
    w.cat_start, w.fill = room_i64(w.cat_start, n_cat + 1), room_i64(w.fill, n_cat)
    cdef unsigned char[::1] clear_o = _set_u8(w.clear_o, n_obs, 0)
    cdef Best b
    for i in range(n_obs):
        b = _best_two(log_g, pairs.start[i], pairs.start[i + 1], NULL)
        best_pair[i], top[i], clear_o[i] = b.index, b.top, _clear(b, gap)
    cdef double[::1] rival = _set_f64(w.rival, n_pairs, -INFINITY)  # per catalog star: its rivals
    for k in range(n_pairs):
        i = pairs.obs[k]
        # An observed star clearly matched to another catalog star is no rival here.
        if cand[k] and not (clear_o[i] and best_pair[i] != k):
            rival[k] = log_g[k]
    # By catalog then observed index: a counting sort of the pairs, which come by
    # observed index, is that order.
    cdef long long[::1] cat_start = _set_i64(w.cat_start, n_cat + 1, 0)
    for k in range(n_pairs):
        cat_start[pairs.cat[k] + 1] += 1
    for j in range(n_cat):
        cat_start[j + 1] += cat_start[j]
    cdef long long[::1] by_cat = w.by_cat[:n_pairs]
    cdef long long[::1] fill = w.fill[:n_cat]
    fill[:] = cat_start[:n_cat]
    for k in range(n_pairs):
        by_cat[fill[pairs.cat[k]]] = k
        fill[pairs.cat[k]] += 1
    cdef unsigned char[::1] clear = _set_u8(w.clear, n_obs, 0)
    for i in range(n_obs):
        k = best_pair[i]
        if k >= 0 and clear_o[i]:
            j = pairs.cat[k]
            b = _best_two(rival, cat_start[j], cat_start[j + 1], &by_cat[0])
            clear[i] = _clear(b, gap) and b.index == k
    return clear


cdef double _log_b_at(Pairs pairs, const double[::1] log_b, Py_ssize_t i, Py_ssize_t j):
    """The brightness term of observed star i's pair with catalog star ``j``, 0 if there
    is none (the dense table's value)."""
    cdef Py_ssize_t k
    for k in range(pairs.start[i], pairs.start[i + 1]):
        if pairs.cat[k] == j:
            return log_b[k]
    return 0.0


cdef Labels label(const double[::1] ox, const double[::1] oy, const double[::1] x,
                  const double[::1] y, const double[::1] mag, const long long[::1] rows,
                  const double[::1] flux, LabelParams p, NearestScratch scratch=None):
    """The final labelling of the observed stars (ox, oy; fluxes ``flux``) against the
    catalog stars projected at (x, y) with magnitudes ``mag`` and catalog ``rows``
    (``scratch``: the frame's pairing buffers to reuse, or None)."""
    cdef Py_ssize_t n_obs = ox.shape[0], n_cat = x.shape[0], i, k
    if scratch is None:
        scratch = NearestScratch.__new__(NearestScratch)
    cdef _Work w = _thread_work()
    w.crowded = room_u8(w.crowded, n_cat)
    # per catalog star, whether another lies closer than sqrt(resolve2) (NaN: none)
    cdef unsigned char[::1] crowded = w.crowded[:n_cat]
    cdef Pairs pairs = pairs_and_crowded(ox, oy, x, y, p.radius2, p.resolve2, scratch,
                                         crowded)
    cdef Py_ssize_t n_pairs = pairs.obs.shape[0], n_false = n_obs, n_unobserved = n_cat
    w.per_cat = room_i64(w.per_cat, n_cat)
    cdef long long[::1] per_cat = _set_i64(w.per_cat, n_cat, 0)
    for k in range(n_pairs):
        per_cat[pairs.cat[k]] += 1
    cdef long long[::1] iso_pair = _isolated(pairs, per_cat, w)
    cdef double sigma = _residual_sigma(pairs, iso_pair, p, w)
    cdef _Fit fit = _brightness(pairs, flux, mag, iso_pair, p, w)
    # Log density (per px^2) of a false star on an unobserved catalog star, and the log
    # probability that a catalog star is observed, from this frame's own counts (plus
    # one, so that a clean frame still allows for one).
    for i in range(n_obs):
        n_false -= pairs.start[i + 1] > pairs.start[i]
    for k in range(n_cat):
        n_unobserved -= per_cat[k] > 0
    cdef double unobserved = (n_unobserved + 1.0) / (n_cat + 2.0)
    cdef double log_false = _log((n_false + 1.0) / p.area * unobserved)
    cdef double log_seen = _log(1.0 - unobserved)
    cdef double log_norm = _log(2.0 * M_PI * (sigma * sigma))  # before dividing by it
    w.log_g = room_f64(w.log_g, n_pairs)
    cdef double[::1] log_g = _set_f64(w.log_g, n_pairs, -INFINITY)  # residual log-likelihoods
    for k in range(n_pairs):
        if fit.ok[k]:
            log_g[k] = -pairs.d2[k] / (2.0 * (sigma * sigma))
    w.best, w.top = room_i64(w.best, n_obs), room_f64(w.top, n_obs)
    cdef long long[::1] best = w.best[:n_obs]
    cdef double[::1] top = w.top[:n_obs]
    cdef unsigned char[::1] clear = _rivals(pairs, fit.ok, log_g, p.log_gap, n_cat, best, top, w)
    cdef _Logs logs = _Logs(log_false, log_seen, log_norm, p.log_false_odds, sigma)
    return _decide(pairs, fit, best, top, clear, crowded, rows, logs, w)



cdef Labels _decide(Pairs pairs, _Fit fit, const long long[::1] best,
                    const double[::1] top, const unsigned char[::1] clear,
                    const unsigned char[::1] crowded, const long long[::1] rows, _Logs logs,
                    _Work w):
    """Each observed star with a candidate reported or withheld (the first rule it
    fails, in the order of startrack.verify._labelling.REASONS)."""
    cdef Py_ssize_t n_obs = best.shape[0], i, k, c, n_ok = 0
    cdef Labels out = Labels.__new__(Labels)
    out.withheld[:] = [0, 0, 0, 0]
    # The pairs in the scratch first, then one new array for both (a numpy array and its
    # typed view cost more than the labelling of a star)
    w.lab_obs, w.lab_cat = room_i64(w.lab_obs, n_obs), room_i64(w.lab_cat, n_obs)
    cdef long long[::1] obs_v = w.lab_obs, cat_v = w.lab_cat
    cdef long long best_cat
    cdef double log_true
    cdef bint any_cand
    for i in range(n_obs):
        if pairs.start[i + 1] == pairs.start[i]:
            continue
        k = best[i]
        best_cat = 0  # numpy's argmax of an all -inf row
        log_true = logs.seen + top[i] - logs.norm
        if k >= 0:
            best_cat = pairs.cat[k]
            log_true = log_true + fit.log_b[k]
        else:
            log_true = log_true + _log_b_at(pairs, fit.log_b, i, 0)
        any_cand = False
        for c in range(pairs.start[i], pairs.start[i + 1]):
            any_cand = any_cand or fit.ok[c]
        if not any_cand:
            out.withheld[0] += 1
        elif crowded.shape[0] and crowded[best_cat]:
            out.withheld[1] += 1
        elif not clear[i]:
            out.withheld[2] += 1
        elif not logs.false_star - log_true <= logs.odds:  # NaN: withheld
            out.withheld[3] += 1
        else:
            obs_v[n_ok], cat_v[n_ok] = i, rows[best_cat]
            n_ok += 1
    cdef long long[::1] both = empty_i64(2 * n_ok)
    for k in range(n_ok):
        both[k], both[n_ok + k] = obs_v[k], cat_v[k]
    out.obs, out.cat = both[:n_ok], both[n_ok:]
    out.sigma_px, out.mag_sigma, out.used = logs.sigma, fit.sigma, fit.used
    return out
