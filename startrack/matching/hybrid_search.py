"""Compiled hybrid search: the observed triples in turn, their catalog triangles among the
shortlisted pairs (:mod:`startrack.matching.hybrid_kernels`), each confirmed by a fourth
observed star; the search returns at each confirmed triangle, so that verification's
first acceptance ends it."""

from __future__ import annotations

import numpy as np
from numba import njit

from startrack.matching.hybrid_kernels import shortlisted_triangles
from startrack.matching.kernels import partners


@njit(cache=True)
def _has_partner(star, other, lo, hi, lists, buf):
    n = partners(star, lo, hi, False, *lists, buf)
    for q in range(min(n, len(buf))):  # noqa: SIM110 (compiled: no generators)
        if buf[q] == other:
            return True
    return False


@njit(cache=True)
def confirm(trip, abc, d, ang, tol, short_d, lists):
    """Candidates (rows of ``trip``, catalog stars for observed a, b, c) that the fourth
    observed star d confirms: a shortlisted catalog star w of d whose pair angles to the
    three catalog stars match those from d to a, b, c. Returns (row index, w), one entry
    per match, in the order of the sorted-key join. ``lists`` are the full pair table's
    neighbour lists (:mod:`startrack.matching.kernels`)."""
    a, b, c = abc[0], abc[1], abc[2]
    buf = np.empty(4096, np.int64)
    side = np.empty(4096, np.int64)
    hit_k, hit_w = [0], [0]
    hit_k.pop()
    hit_w.pop()
    for k in range(len(trip)):
        n_w = partners(trip[k, 0], ang[a, d] - tol, ang[a, d] + tol, a > d, *lists, side)
        for q in range(min(n_w, len(side))):
            w = side[q]
            if not short_d[w]:
                continue
            if not _has_partner(trip[k, 1], w, ang[b, d] - tol, ang[b, d] + tol, lists, buf):
                continue
            if not _has_partner(trip[k, 2], w, ang[c, d] - tol, ang[c, d] + tol, lists, buf):
                continue
            hit_k.append(k)
            hit_w.append(w)
    return np.array(hit_k, np.int64), np.array(hit_w, np.int64)


@njit(cache=True)
def next_triangles(start, triples, feats, hands, lists, cat, k, heads, tested):
    """The first triple (a, b, c), from index ``start`` on, with catalog triangles among
    the shortlisted pairs (:func:`shortlisted_triangles` on (a, b) and (b, c)): (its index,
    rows, err); the index is len(triples) when none is left. ``tested[0]`` counts the
    triplets tested."""
    n = int(np.sqrt(len(lists[0]) - 1))
    for t in range(start, len(triples)):
        a, b, c = triples[t, 0], triples[t, 1], triples[t, 2]
        rows, err, n_tested = shortlisted_triangles(lists, a * n + b, b * n + c, cat,
                                                    feats[t], k, hands[t], heads)
        tested[0] += n_tested
        if len(rows):
            return t, rows, err
    return len(triples), np.empty((0, 3), np.int64), np.empty(0)


@njit(cache=True)
def _keep_best(best_rows, best_err, count, abc, trip, e):
    """Insert triangle ``trip`` of triple ``abc`` with error ``e`` into the best so far
    (ascending error, ties in arrival order: a stable sort's), at most len(best_err) of
    them; return how many are kept."""
    cap = len(best_err)
    i = min(count, cap)
    while i > 0 and best_err[i - 1] > e:
        i -= 1
    if i >= cap:
        return count
    for j in range(min(count, cap - 1), i, -1):
        best_rows[j] = best_rows[j - 1]
        best_err[j] = best_err[j - 1]
    best_rows[i, :3] = abc
    best_rows[i, 3:] = trip
    best_err[i] = e
    return min(count + 1, cap)


@njit(cache=True)
def next_confirmed(start, triples, feats, hands, lists, cat, k, heads, ang, tol, short,
                   full, keep_n, best_rows, best_err, stats):
    """From triple index ``start`` on, the first triple whose ``keep_n`` best catalog
    triangles a fourth observed star d confirms (:func:`confirm`, the stars d in turn):
    (its index, d, rows of catalog stars for (a, b, c, d)); index len(triples) when none
    is left. Triangles no star confirms go to the best-so-far (``best_rows`` (K x 6)
    as (a, b, c, x, y, z), ``best_err``). ``stats`` counts (triplets tested, fourth stars
    tried, best kept)."""
    n = short.shape[0]
    for t in range(start, len(triples)):
        abc = triples[t]
        rows, err, tested = shortlisted_triangles(lists, abc[0] * n + abc[1],
                                                  abc[1] * n + abc[2], cat, feats[t], k,
                                                  hands[t], heads)
        stats[0] += tested
        if len(rows) == 0:
            continue
        keep = np.argsort(err, kind="mergesort")[:keep_n]
        trip = rows[keep]
        for d in range(n):
            if d == abc[0] or d == abc[1] or d == abc[2]:
                continue
            stats[1] += 1
            hit, w = confirm(trip, abc, d, ang, tol, short[d], full)
            if len(hit):
                out = np.empty((len(hit), 4), np.int64)
                for h in range(len(hit)):
                    out[h, :3] = trip[hit[h]]
                    out[h, 3] = w[h]
                return t, d, out
        for r in range(len(keep)):
            stats[2] = _keep_best(best_rows, best_err, stats[2], abc, trip[r], err[keep[r]])
    return len(triples), -1, np.empty((0, 4), np.int64)
