"""Compiled planar-triangle search: the triangle matcher's triples, lookups and pivots.

Each observed triple in turn is looked up (:func:`startrack.matching.triangle_lookup.lookup`);
while more than one hypothesis is left (or fewer than ``min_stars`` stars are in), the
search pivots on a triangle that shares the newest two stars (or, with ``pivot_first``,
two stars of the first triangle: the 2011 paper's reading) and joins the two on them by
a sorted key (:func:`join_pivot`). :func:`next_answer` returns at each triple that leaves
an answer, so that verification's first acceptance ends the search; the counters and
the lookups' memo carry over between calls. See :mod:`startrack.matchers.planar_triangle`
for the method.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from startrack.matching.triangle_lookup import PIVOTS, lookup


@njit(cache=True)
def join_pivot(left, col_p, col_q, right):
    """:func:`startrack.matching.pairs.join_sorted` (left, (col_p, col_q), right) compiled:
    each row of ``left`` once per row of ``right`` (K x 3) whose first two columns equal
    the row's columns (col_p, col_q), that right row's last column appended (right rows
    in their own order); a row whose new star is already in it goes."""
    m, w = left.shape
    if m == 0 or len(right) == 0:
        return np.zeros((0, w + 1), np.int64)
    base = max(left.max(), right.max()) + 1
    keys = right[:, 0] * base + right[:, 1]
    order = np.argsort(keys, kind="mergesort")
    keys = keys[order]
    out = np.empty((max(m, 16), w + 1), np.int64)
    count = 0
    for r in range(m):
        key = left[r, col_p] * base + left[r, col_q]
        p = np.searchsorted(keys, key)
        while p < len(keys) and keys[p] == key:
            new = right[order[p], 2]
            p += 1
            if _holds(left[r], w, new):
                continue
            if count == len(out):
                out = np.concatenate((out, np.empty_like(out)))
            out[count, :w] = left[r]
            out[count, w] = new
            count += 1
    return out[:count]


@njit(cache=True, inline="always")
def _holds(row, w, x):
    for col in range(w):  # noqa: SIM110 (compiled: no generators)
        if row[col] == x:
            return True
    return False


@njit(cache=True)
def _pivots(hyps, stars, frame, table, memo, state, min_stars, pivot_first):
    """Pivot from the triple in ``stars[:3]`` while more than one row is left or fewer
    than ``min_stars`` stars are in: a triangle (newest two chain stars, or the first
    triangle's last two when ``pivot_first``, and a new star in index order) joined on
    the shared two. Returns (rows, number of chain stars, memo)."""
    n = frame[0].shape[0]
    n_stars, cp, cq = 3, 1, 2
    while len(hyps) > 1 or n_stars < min_stars:
        found = False
        for extra in range(n):
            if _holds(stars, n_stars, extra):
                continue
            state[PIVOTS] += 1
            right, memo = lookup(stars[cp], stars[cq], extra, frame, table, memo, state)
            joined = join_pivot(hyps, cp, cq, right)
            if len(joined):
                hyps = joined
                stars[n_stars] = extra
                if not pivot_first:
                    cp, cq = cq, n_stars
                n_stars += 1
                found = True
                break
        if not found:
            break  # stars ran out: the survivors go to verification
    return hyps, n_stars, memo


@njit(cache=True)
def next_answer(start, triples, frame, table, memo, state, min_stars, max_ambiguous,
                pivot_first=False):
    """From triple ``start`` on, the first whose lookup leaves catalog triangles: (its
    index, chain stars, at most ``max_ambiguous`` rows of catalog stars after the pivots,
    memo); the index is len(triples) when none is left.

    ``frame`` is :func:`startrack.matching.triangle_lookup.frame_tuple`'s; ``table`` the
    triangle table's (area, k-vector k, m, q, polar, rows) and the catalog vectors;
    ``memo`` (:func:`~startrack.matching.triangle_lookup.frame_memo`'s, pass on the one
    returned) and ``state`` (the counters) carry over between calls. ``pivot_first``:
    every pivot triangle shares two stars with the first one (see :func:`_pivots`)."""
    stars = np.empty(frame[0].shape[0], np.int64)
    for t in range(start, len(triples)):
        a, b, c = triples[t, 0], triples[t, 1], triples[t, 2]
        hyps, memo = lookup(a, b, c, frame, table, memo, state)
        if len(hyps) == 0:
            continue  # a false star, or a star outside the pattern set
        stars[0], stars[1], stars[2] = a, b, c
        hyps, n_stars, memo = _pivots(hyps, stars, frame, table, memo, state, min_stars,
                                      pivot_first)
        return t, stars[:n_stars].copy(), hyps[:max_ambiguous].copy(), memo
    return len(triples), stars[:0].copy(), np.empty((0, 3), np.int64), memo
