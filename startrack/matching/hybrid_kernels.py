"""Compiled hybrid steps: angle votes, the shortlisted pairs of each observed pair, the
catalog triplets joined from two of them whose planar area and polar moment match the
observed triangle's, and the observed triangles' features."""

from __future__ import annotations

import numpy as np
from numba import njit

from startrack.database.build_kernels import triangle_features_one
from startrack.matching.feature_kernels import features


@njit(cache=True)
def _sign(x):
    return (x > 0) - (x < 0)


@njit(cache=True)
def _pair_lists(pi, pj, windows, short, fill, xs, ys, start):
    m = 0
    n = short.shape[0]
    for a in range(n):
        for b in range(n):
            start[a * n + b] = m
            if b <= a:
                continue
            for half in range(2):
                for e in range(windows[a, b, 0], windows[a, b, 1]):
                    x, y = (pi[e], pj[e]) if half == 0 else (pj[e], pi[e])
                    if short[a, x] and short[b, y]:
                        if fill:
                            xs[m], ys[m] = x, y
                        m += 1
    start[n * n] = m
    return m


@njit(cache=True)
def shortlisted_pairs(pi, pj, windows, short):
    """Each observed pair's catalog pairs among the shortlisted stars, as (start, xs, ys):
    for a < b, the pairs (xs[p], ys[p]), p in [start[a*n + b], start[a*n + b + 1]), are the
    entries of the window ``windows[a, b]`` seen both ways round, x shortlisted for a and y
    for b: first every entry as (i, j), in table order, then every entry as (j, i)."""
    n = short.shape[0]
    start = np.zeros(n * n + 1, np.int64)
    none = np.empty(0, np.int64)
    m = _pair_lists(pi, pj, windows, short, False, none, none, start)
    xs, ys = np.empty(m, np.int64), np.empty(m, np.int64)
    _pair_lists(pi, pj, windows, short, True, xs, ys, start)
    return start, xs, ys


@njit(cache=True)
def _feature_test(cat, x, y, z, features, k, hand):
    """Error in sigmas of the catalog triangle (x, y, z) against ``features``; -1 when its
    area, polar moment or (unless ``hand`` is 0) handedness does not match."""
    area, polar, s_area, s_polar = features[0], features[1], features[2], features[3]
    ca, cp = triangle_features_one(cat, x, y, z)
    if abs(ca - area) > k * s_area or abs(cp - polar) > k * s_polar:
        return -1.0
    if hand != 0:
        t = (cat[x, 0] * (cat[y, 1] * cat[z, 2] - cat[y, 2] * cat[z, 1])
             + cat[x, 1] * (cat[y, 2] * cat[z, 0] - cat[y, 0] * cat[z, 2])
             + cat[x, 2] * (cat[y, 0] * cat[z, 1] - cat[y, 1] * cat[z, 0]))
        if _sign(t) != hand:
            return -1.0
    return np.hypot((ca - area) / s_area, (cp - polar) / s_polar)


@njit(cache=True)
def shortlisted_triangles(lists, ab, bc, cat, features, k, hand, heads):
    """Triplets (x, y, z), x != z: (x, y) a pair of observed pair ``ab`` and (y, z) one of
    ``bc`` in :func:`shortlisted_pairs`'s ``lists``, whose area and polar moment lie within
    ``k`` sigmas of ``features`` = (area, polar, sigma_area, sigma_polar) and, unless
    ``hand`` is 0, whose handedness is ``hand``. Rows in the order of the (x, y) pairs,
    then of y's pairs in bc. Returns (rows, err in sigmas, how many triplets were tested).
    ``heads`` is an all -1 scratch array over the catalog, left so."""
    start, xs, ys = lists
    s0, s1 = start[bc], start[bc + 1]
    nxt = np.empty(s1 - s0, np.int64)
    for p in range(s1 - 1, s0 - 1, -1):  # linked backwards: y's partners come out forwards
        nxt[p - s0] = heads[xs[p]]
        heads[xs[p]] = p
    rows = np.empty((64, 3), np.int64)
    err = np.empty(64)
    m = tested = 0
    for q in range(start[ab], start[ab + 1]):
        x, y = xs[q], ys[q]
        p = heads[y]
        while p >= 0:
            z = ys[p]
            p = nxt[p - s0]
            if z == x:
                continue
            tested += 1
            e = _feature_test(cat, x, y, z, features, k, hand)
            if e < 0:
                continue
            if m == len(rows):
                rows = np.concatenate((rows, np.empty_like(rows)))
                err = np.concatenate((err, np.empty_like(err)))
            rows[m, 0], rows[m, 1], rows[m, 2] = x, y, z
            err[m] = e
            m += 1
    for p in range(s0, s1):
        heads[xs[p]] = -1
    return rows[:m], err[:m], tested


@njit(cache=True)
def angle_votes(pi, pj, windows, n_catalog):
    """Votes (n x catalog rows, int16): in how many of observed star a's pair windows each
    catalog star appears, once per window however many of its pairs it is in.
    ``windows`` (n x n x 2) holds each observed pair's table entries [start, stop)."""
    n = windows.shape[0]
    votes = np.zeros((n, n_catalog), np.int16)
    stamp = np.full(n_catalog, -1, np.int64)
    for a in range(n):
        for b in range(a + 1, n):
            key = a * n + b
            for e in range(windows[a, b, 0], windows[a, b, 1]):
                for x in (pi[e], pj[e]):
                    if stamp[x] != key:
                        stamp[x] = key
                        votes[a, x] += 1
                        votes[b, x] += 1
    return votes


@njit(cache=True)
def triple_features(vectors, triples, sigma):
    """(area, polar, sigma_area, sigma_polar) of each observed triple (rows of
    ``triples``): :func:`startrack.matching.feature_kernels.features`, for one frame's
    few triples."""
    out = np.empty((len(triples), 4))
    for t in range(len(triples)):
        out[t, 0], out[t, 1], out[t, 2], out[t, 3] = features(
            vectors[triples[t, 0]], vectors[triples[t, 1]], vectors[triples[t, 2]], sigma)
    return out
