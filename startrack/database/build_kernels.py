"""Compiled (numba) loops of the database builds: the triangles of a pair graph with their
canonical vertex order, area and polar moment, in one pass."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from startrack.database.sort_kernels import stable_argsort  # noqa: F401 (its old home)


@njit(cache=True)
def _forward_lists(n, lo, hi):
    """CSR of the forward neighbours k > i of each star, ascending."""
    start = np.zeros(n + 1, np.int64)
    for e in range(len(lo)):
        start[lo[e] + 1] += 1
    for s in range(n):
        start[s + 1] += start[s]
    fill = start[:-1].copy()
    nbr = np.empty(len(lo), np.int64)
    for e in range(len(lo)):
        nbr[fill[lo[e]]] = hi[e]
        fill[lo[e]] += 1
    for s in range(n):
        nbr[start[s]:start[s + 1]] = np.sort(nbr[start[s]:start[s + 1]])
    return start, nbr


@njit(cache=True)
def _dist(v, a, b):
    dx, dy, dz = v[a, 0] - v[b, 0], v[a, 1] - v[b, 1], v[a, 2] - v[b, 2]
    return math.sqrt(dx * dx + dy * dy + dz * dz)


@njit(cache=True)
def triangle_features_one(v, a, b, c):
    """(area, polar moment) of the planar triangle through the tips of v[a], v[b], v[c]."""
    ux, uy, uz = v[b, 0] - v[a, 0], v[b, 1] - v[a, 1], v[b, 2] - v[a, 2]
    wx, wy, wz = v[c, 0] - v[a, 0], v[c, 1] - v[a, 1], v[c, 2] - v[a, 2]
    cx, cy, cz = uy * wz - uz * wy, uz * wx - ux * wz, ux * wy - uy * wx
    area = 0.5 * math.sqrt(cx * cx + cy * cy + cz * cz)
    s1, s2, s3 = _dist(v, a, b), _dist(v, b, c), _dist(v, a, c)
    return area, area * (s1 * s1 + s2 * s2 + s3 * s3) / 36.0


@njit(cache=True)
def triangles_of_pairs(n, lo, hi, vectors):
    """Every (i, j, k), i < j < k, whose three pairs are all among the pairs (lo < hi), in
    lexicographic order, each reordered so that vertex 0 faces the shortest side and
    vertex 2 the longest. Returns (rows (M x 3), area, polar)."""
    start, nbr = _forward_lists(n, lo, hi)
    mark = np.zeros(n, np.bool_)
    count = 0
    for i in range(n):  # first pass: count, so that the output is allocated once
        for p in range(start[i], start[i + 1]):
            mark[nbr[p]] = True
        for p in range(start[i], start[i + 1]):
            j = nbr[p]
            for q in range(start[j], start[j + 1]):
                count += mark[nbr[q]]
        for p in range(start[i], start[i + 1]):
            mark[nbr[p]] = False
    rows = np.empty((count, 3), np.int64)
    area = np.empty(count)
    polar = np.empty(count)
    t = 0
    opp = np.empty(3)
    for i in range(n):
        for p in range(start[i], start[i + 1]):
            mark[nbr[p]] = True
        for p in range(start[i], start[i + 1]):
            j = nbr[p]
            for q in range(start[j], start[j + 1]):
                k = nbr[q]
                if not mark[k]:
                    continue
                verts = (i, j, k)
                opp[0], opp[1], opp[2] = _dist(vectors, j, k), _dist(vectors, i, k), \
                    _dist(vectors, i, j)
                first, last = np.argmin(opp), np.argmax(opp)
                if last == first:  # three equal sides
                    last = (first + 2) % 3
                rows[t, 0], rows[t, 1] = verts[first], verts[3 - first - last]
                rows[t, 2] = verts[last]
                area[t], polar[t] = triangle_features_one(vectors, rows[t, 0], rows[t, 1],
                                                          rows[t, 2])
                t += 1
        for p in range(start[i], start[i + 1]):
            mark[nbr[p]] = False
    return rows, area, polar


@njit(cache=True)
def close_pairs(vectors, max_angle):
    """Every pair (i < j) of unit vectors closer than ``max_angle``, with its angle: stars
    sorted by z, each compared only with those in the z band the angle allows."""
    n = len(vectors)
    order = np.argsort(vectors[:, 2])
    # The sweep reads the stars in z order: copied so, the inner loop runs along memory.
    x, y, z = np.empty(n), np.empty(n), np.empty(n)
    for a in range(n):
        x[a], y[a], z[a] = vectors[order[a], 0], vectors[order[a], 1], vectors[order[a], 2]
    band = 2.0 * math.sin(max_angle / 2.0)  # |dz| <= chord
    cos_max = math.cos(max_angle)
    cap = 1024
    pi, pj = np.empty(cap, np.int64), np.empty(cap, np.int64)
    ang = np.empty(cap)
    m = 0
    for a in range(n):
        i = order[a]
        for b in range(a + 1, n):
            if z[b] - z[a] > band:
                break
            d = x[a] * x[b] + y[a] * y[b] + z[a] * z[b]
            if d < cos_max:
                continue
            if m == cap:
                cap *= 2
                pi, pj, ang = _grow(pi, cap), _grow(pj, cap), _grow(ang, cap)
            j = order[b]
            pi[m], pj[m] = min(i, j), max(i, j)
            ang[m] = math.acos(min(max(d, -1.0), 1.0))
            m += 1
    return pi[:m], pj[:m], ang[:m]


@njit(cache=True)
def _grow(a, size):
    out = np.empty(size, a.dtype)
    out[:len(a)] = a
    return out
