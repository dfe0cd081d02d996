"""Compiled (numba) kernels on pair tables: neighbour lists, windowed partner search, joins.

A pair table lists catalog pairs (i < j) sorted by angle. Its neighbour lists give, for
each catalog star s, its partners in the pairs where s is the first star (``lo`` run) and
in those where it is the second (``hi`` run), each run in table order, so by angle: the
partners of s within an angle window are two binary searches away. The "lists" argument
of a kernel is (start_lo, nbr_lo, ang_lo, start_hi, nbr_hi, ang_hi). Entry order is kept
throughout, so that the compiled joins give the rows in the order a stable sort would.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from startrack.database.sort_kernels import first_at_least


@njit(cache=True)
def neighbour_lists(pi, pj, angle, n):
    """(start_lo, nbr_lo, ang_lo, start_hi, nbr_hi, ang_hi): the partners of star s as
    first star of a pair are ``nbr_lo[start_lo[s]:start_lo[s + 1]]`` with the pair angles
    in ``ang_lo``, as second star in ``nbr_hi`` and ``ang_hi``. Partners and angles sit
    side by side per star: a window search then reads a few cache lines, not the table."""
    m = len(pi)
    start_lo = np.zeros(n + 1, np.int64)
    start_hi = np.zeros(n + 1, np.int64)
    for e in range(m):
        start_lo[pi[e] + 1] += 1
        start_hi[pj[e] + 1] += 1
    for s in range(n):
        start_lo[s + 1] += start_lo[s]
        start_hi[s + 1] += start_hi[s]
    fill_lo = start_lo[:-1].copy()
    fill_hi = start_hi[:-1].copy()
    nbr_lo = np.empty(m, np.int32)
    nbr_hi = np.empty(m, np.int32)
    ang_lo = np.empty(m, np.float64)
    ang_hi = np.empty(m, np.float64)
    for e in range(m):
        a, b = pi[e], pj[e]
        nbr_lo[fill_lo[a]], ang_lo[fill_lo[a]] = b, angle[e]
        fill_lo[a] += 1
        nbr_hi[fill_hi[b]], ang_hi[fill_hi[b]] = a, angle[e]
        fill_hi[b] += 1
    return start_lo, nbr_lo, ang_lo, start_hi, nbr_hi, ang_hi


@njit(cache=True)
def partners(star, lo, hi, hi_first, start_lo, nbr_lo, ang_lo, start_hi, nbr_hi, ang_hi,
             out):
    """Write the partners of ``star`` whose pair angle lies in [lo, hi] into ``out``; return
    how many. The ``lo`` run comes first unless ``hi_first``: the order of a stable sort
    of the pairs seen one way round or the other. Writes at most len(out)."""
    count = 0
    for run in range(2):
        if (run == 0) == hi_first:
            nbr, ang, a, b = nbr_hi, ang_hi, start_hi[star], start_hi[star + 1]
        else:
            nbr, ang, a, b = nbr_lo, ang_lo, start_lo[star], start_lo[star + 1]
        p = first_at_least(ang, a, b, lo)
        while p < b and ang[p] <= hi:
            if count < len(out):
                out[count] = nbr[p]
            count += 1
            p += 1
    return count


@njit(cache=True)
def group_window(pi, pj, s0, s1, hi_first, head, nxt, val):
    """Link the pairs of table entries [s0, s1), both ways round, into per-star lists:
    star x's partners are val[p] for p = head[x], nxt[p], ... until -1, in the order of a
    stable sort of the pairs by x (x as first star first, unless ``hi_first``). ``head``
    must be all -1; the caller resets it with :func:`ungroup_window`. Reads the window in
    sequence and writes only into the small per-frame arrays, which stay in cache."""
    w = s1 - s0
    for step in range(2):  # insert backwards: lists come out forwards
        half = step if hi_first else 1 - step
        for e in range(s1 - 1, s0 - 1, -1):
            x, y = (pi[e], pj[e]) if half == 0 else (pj[e], pi[e])
            p = (e - s0) + half * w
            nxt[p] = head[x]
            val[p] = y
            head[x] = p


@njit(cache=True)
def ungroup_window(pi, pj, s0, s1, head):
    for e in range(s0, s1):
        head[pi[e]] = -1
        head[pj[e]] = -1


@njit(cache=True)
def linked(head, nxt, val, x, y):
    p = head[x]
    while p >= 0:
        if val[p] == y:
            return True
        p = nxt[p]
    return False


@njit(cache=True)
def group_pairs(pi, pj, s0, s1, hi_first, n_catalog):
    """:func:`group_window` into fresh arrays: (head, nxt, val)."""
    head = np.full(n_catalog, -1, np.int64)
    nxt, val = np.empty(2 * (s1 - s0), np.int64), np.empty(2 * (s1 - s0), np.int64)
    group_window(pi, pj, s0, s1, hi_first, head, nxt, val)
    return head, nxt, val


@njit(cache=True)
def join_extend(hyps, col, head, nxt, val, max_rows):
    """Each row of ``hyps`` once per partner of its column ``col`` in the grouped pairs
    (head, nxt, val; see :func:`group_window`), the partner appended; partners already in
    the row are refused. Returns (rows, total): total counts every joined row, rows holds
    at most ``max_rows`` of them."""
    cap = min(max_rows, 1024)
    while True:  # a second pass only when the first guess of the row count was short
        out = np.empty((cap, hyps.shape[1] + 1), np.int64)
        count = _join_fill(hyps, col, head, nxt, val, out)
        if count <= cap or cap == max_rows:
            return out[:min(count, cap)], count
        cap = min(count, max_rows)


@njit(cache=True)
def _join_fill(hyps, col, head, nxt, val, out):
    """:func:`join_extend`'s rows written into ``out`` while it has room; returns how
    many there are in all (``out`` is never reassigned here, which keeps numba's
    reference counting out of the loop)."""
    m, w = hyps.shape
    cap = out.shape[0]
    count = 0
    for r in range(m):
        p = head[hyps[r, col]]
        while p >= 0:
            new = val[p]
            p = nxt[p]
            clash = False
            for c in range(w):
                clash |= hyps[r, c] == new
            if clash:
                continue
            if count < cap:
                for c in range(w):
                    out[count, c] = hyps[r, c]
                out[count, w] = new
            count += 1
    return count


@njit(cache=True)
def join_close(hyps, col_p, col_q, head, nxt, val):
    """The rows of ``hyps`` whose catalog stars in columns (col_p, col_q) are one of the
    grouped pairs."""
    keep = np.zeros(len(hyps), np.bool_)
    for r in range(len(hyps)):
        keep[r] = linked(head, nxt, val, hyps[r, col_p], hyps[r, col_q])
    return hyps[keep]
