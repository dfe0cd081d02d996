"""Compiled hybrid step: catalog triplets of shortlisted stars joined from two pair
windows, kept when their planar area and polar moment match the observed triangle's."""

from __future__ import annotations

import numpy as np
from numba import njit

from startrack.database.build_kernels import triangle_features_one
from startrack.matching.kernels import group_window, partners, ungroup_window


@njit(cache=True)
def _sign(x):
    return (x > 0) - (x < 0)


@njit(cache=True)
def shortlisted_triangles(pi, pj, ab, bc, short_a, short_b, short_c, cat, features, k,
                          hand, heads):
    """Triplets (x, y, z): (x, y) a pair of table entries ab = (start, stop), seen both ways
    round, (y, z) one of bc, x != z, each star in its observed star's shortlist, whose
    area and polar moment lie within ``k`` sigmas of ``features`` = (area, polar,
    sigma_area, sigma_polar) and, unless ``hand`` is 0, whose handedness is ``hand``.
    Rows come in the order of the sorted-key join. Returns (rows, err in sigmas, how many
    triplets were tested). ``heads`` is an all -1 scratch array over the catalog."""
    area, polar, s_area, s_polar = features[0], features[1], features[2], features[3]
    t0, t1 = bc[0], bc[1]
    nxt, val = np.empty(2 * (t1 - t0), np.int64), np.empty(2 * (t1 - t0), np.int64)
    group_window(pi, pj, t0, t1, False, heads, nxt, val)
    cap = 64
    rows = np.empty((cap, 3), np.int64)
    err = np.empty(cap)
    m = 0
    tested = 0
    for half in range(2):
        for e in range(ab[0], ab[1]):
            x, y = (pi[e], pj[e]) if half == 0 else (pj[e], pi[e])
            if not (short_a[x] and short_b[y]):
                continue
            p = heads[y]
            while p >= 0:
                z = val[p]
                p = nxt[p]
                if z == x or not short_c[z]:
                    continue
                tested += 1
                ca, cp = triangle_features_one(cat, x, y, z)
                if abs(ca - area) > k * s_area or abs(cp - polar) > k * s_polar:
                    continue
                if hand != 0:
                    t = (cat[x, 0] * (cat[y, 1] * cat[z, 2] - cat[y, 2] * cat[z, 1])
                         + cat[x, 1] * (cat[y, 2] * cat[z, 0] - cat[y, 0] * cat[z, 2])
                         + cat[x, 2] * (cat[y, 0] * cat[z, 1] - cat[y, 1] * cat[z, 0]))
                    if _sign(t) != hand:
                        continue
                if m == cap:
                    cap *= 2
                    grown, grown_err = np.empty((cap, 3), np.int64), np.empty(cap)
                    grown[:m], grown_err[:m] = rows[:m], err[:m]
                    rows, err = grown, grown_err
                rows[m, 0], rows[m, 1], rows[m, 2] = x, y, z
                err[m] = np.hypot((ca - area) / s_area, (cp - polar) / s_polar)
                m += 1
    ungroup_window(pi, pj, t0, t1, heads)
    return rows[:m], err[:m], tested


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
