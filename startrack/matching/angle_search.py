"""Compiled angle-with-pivoting search: the angle matcher's chains of pair lookups and joins.

Each chain starts from one star triple and pivots through the other stars in turn (see
:mod:`startrack.matchers.angle` for the method). The lookups are the observed pairs'
windows in the pair table; the joins are the shared ones of
:mod:`startrack.matching.kernels`, each over a pair window grouped once per frame.
:func:`next_chain` returns at each chain that leaves an answer, so that verification's
first acceptance ends the search; its counters and groupings carry over between calls.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from startrack.matching.kernels import group_window, join_close, join_extend, linked
from startrack.matching.verify_kernels import fitting_rows

#: ``state`` entries: lookup budget left, last chain started (1-based), pivots, database
#: candidates, distinct pair lookups, stars skipped, ambiguous answers, and which of the
#: last two happened first (0 while neither has).
BUDGET, CHAINS, PIVOTS, CANDIDATES, LOOKUPS, SKIPPED, AMBIGUOUS, FIRST_EVENT = range(8)
#: ``closing`` codes, in the order of :data:`startrack.matchers.angle.CLOSING`.
UNTIL_ONE, ALL, NONE = range(3)


def frame_arrays(windows: np.ndarray, n_slots: int, store_rows: int = 1 << 14,
                 ) -> tuple[tuple[np.ndarray, ...], tuple[np.ndarray, ...]]:
    """Per-frame storage of :func:`next_chain`: the pair groupings (heads, nxt, val,
    offsets, done) and the triangles of the first pairs (info, store, fill). Each ordered
    observed pair (p, q) gets a row of ``heads`` and the stretch of ``nxt`` and ``val``
    from ``offsets[p * n + q]``, filled the first time it is asked for (``done``). Each
    ordered triple (a, b, q) gets a row of ``info`` (status, joined rows, total, start and
    length in ``store``); ``store`` holds at most ``store_rows`` triangles."""
    n = windows.shape[0]
    sizes = 2 * (windows[..., 1] - windows[..., 0]).clip(0)
    np.fill_diagonal(sizes, 0)
    offsets = np.concatenate([[0], np.cumsum(sizes.ravel())]).astype(np.int64)
    groups = (np.empty((n * n, n_slots), np.int32), np.empty(offsets[-1], np.int32),
              np.empty(offsets[-1], np.int32), offsets, np.zeros(n * n, np.bool_))
    memo = (np.zeros((n ** 3, 5), np.int64), np.empty((store_rows, 3), np.int64),
            np.zeros(1, np.int64))
    return groups, memo


@njit(cache=True)
def _touch(p, q, windows, seen, state):
    """Count the first lookup of the observed pair {p, q} as database candidates."""
    a, b = min(p, q), max(p, q)
    if not seen[a, b]:
        seen[a, b] = True
        state[CANDIDATES] += windows[p, q, 1] - windows[p, q, 0]
        state[LOOKUPS] += 1


@njit(cache=True)
def _first_pairs(p, q, windows, pi, pj):
    """The catalog pairs of (p, q) as rows (star of p, star of q): the window in table
    order one way round, then the other."""
    s0, s1 = windows[p, q, 0], windows[p, q, 1]
    w = max(s1 - s0, 0)
    rows = np.empty((2 * w, 2), np.int64)
    for e in range(s0, s1):
        i, j = (pj[e], pi[e]) if p > q else (pi[e], pj[e])
        rows[e - s0, 0], rows[e - s0, 1] = i, j
        rows[w + e - s0, 0], rows[w + e - s0, 1] = j, i
    return rows


@njit(cache=True)
def _grouped(p, q, frame, groups):
    """The window of (p, q) grouped per star of p (:func:`group_window`), built once per
    frame: (head, nxt, val)."""
    windows, pi, pj = frame[0], frame[3], frame[4]
    heads, nxt, val, offsets, done = groups
    k = p * windows.shape[0] + q
    o0, o1 = offsets[k], offsets[k + 1]
    if not done[k]:
        done[k] = True
        heads[k, :] = -1
        group_window(pi, pj, windows[p, q, 0], windows[p, q, 1], p > q, heads[k],
                     nxt[o0:o1], val[o0:o1])
    return heads[k], nxt[o0:o1], val[o0:o1]


@njit(cache=True)
def _extend(hyps, col, p, q, frame, groups, max_rows):
    """:func:`startrack.matching.pairs.join_extend` on the window of (p, q)."""
    windows, seen, state = frame[0], frame[1], frame[2]
    _touch(p, q, windows, seen, state)
    if windows[p, q, 1] <= windows[p, q, 0]:
        return np.zeros((0, hyps.shape[1] + 1), np.int64), 0
    head, nxt, val = _grouped(p, q, frame, groups)
    return join_extend(hyps, col, head, nxt, val, max_rows)


@njit(cache=True)
def _close(hyps, col_p, col_q, p, q, frame, groups):
    """:func:`startrack.matching.pairs.join_close` on the window of (p, q): the same pair
    set either way round, so an existing grouping of (q, p) serves."""
    windows, seen, state = frame[0], frame[1], frame[2]
    _touch(p, q, windows, seen, state)
    if windows[p, q, 1] <= windows[p, q, 0]:
        return hyps[:0]
    if groups[4][q * windows.shape[0] + p]:
        p, q = q, p
    head, nxt, val = _grouped(p, q, frame, groups)
    return join_close(hyps, col_p, col_q, head, nxt, val)


@njit(cache=True)
def _pivot(hyps, cols, n_cols, q, frame, groups, params):
    """One pivot to star q: the join on (newest chain star, q), then the closing pairs (q,
    earlier chain star) while ``params``' closing code asks for them. (rows, total)."""
    state = frame[2]
    max_rows, closing = params[2], params[3]
    state[BUDGET] -= 1
    state[PIVOTS] += 1
    rows, total = _extend(hyps, n_cols - 1, cols[n_cols - 1], q, frame, groups, max_rows + 1)
    for col_t in range(n_cols - 1 if closing != NONE else 0):
        if state[BUDGET] <= 0 or total > max_rows or len(rows) == 0 or (
                len(rows) == 1 and closing == UNTIL_ONE):
            break
        state[BUDGET] -= 1
        state[PIVOTS] += 1
        rows = _close(rows, n_cols, col_t, q, cols[col_t], frame, groups)
    return rows, total


@njit(cache=True)
def _joined(a, b, q, pairs, frame, groups, max_rows):
    """The pair rows of (a, b) (built if ``pairs`` is still empty) joined on (b, q):
    (rows, total, pairs)."""
    if len(pairs) == 0:
        pairs = _first_pairs(a, b, frame[0], frame[3], frame[4])
    rows, total = _extend(pairs, 1, b, q, frame, groups, max_rows + 1)
    return rows, total, pairs


@njit(cache=True)
def _triangles(a, b, q, frame, groups):
    """The pair rows of (a, b) joined on (b, q) and narrowed by (q, a) without the rows
    in between (:func:`_joined`, then :func:`_close`): (rows, rows joined on (b, q)).
    Counts nothing."""
    windows, pi, pj, done = frame[0], frame[3], frame[4], groups[4]
    rows = np.empty((16, 3), np.int64)
    if windows[b, q, 1] <= windows[b, q, 0]:
        return rows[:0], 0
    head, nxt, val = _grouped(b, q, frame, groups)
    closes = windows[q, a, 1] > windows[q, a, 0]
    c_head, c_nxt, c_val = head, nxt, val
    if closes:
        n = windows.shape[0]
        c_head, c_nxt, c_val = _grouped(a, q, frame, groups) if done[a * n + q] else \
            _grouped(q, a, frame, groups)
    m = total = 0
    for half in range(2):  # _first_pairs' order
        for e in range(windows[a, b, 0], windows[a, b, 1]):
            x, y = (pj[e], pi[e]) if (a > b) == (half == 0) else (pi[e], pj[e])
            p = head[y]
            while p >= 0:
                z = val[p]
                p = nxt[p]
                if z == x or z == y:  # noqa: SIM109 (compiled: no tuple search)
                    continue
                total += 1
                if closes and linked(c_head, c_nxt, c_val, z, x):
                    if m == len(rows):
                        rows = np.concatenate((rows, np.empty_like(rows)))
                    rows[m, 0], rows[m, 1], rows[m, 2] = x, y, z
                    m += 1
    return rows[:m], total


@njit(cache=True)
def _pair_step(a, b, q, pairs, frame, groups, memo, params):
    """:func:`_pivot` from the chain's first pair (a, b) to q: the triangles (a, b, q),
    which the chains that share a first pair ask for again and again. Their counts, and
    their rows when they fit into ``memo``'s store, are kept for the frame; the counters
    advance as if each were found anew. ``pairs`` are the pair rows, empty until a pivot
    needs them. Returns (rows, total, pairs)."""
    windows, seen, state = frame[0], frame[1], frame[2]
    info, store, fill = memo
    max_rows, closing = params[2], params[3]
    key = (a * windows.shape[0] + b) * windows.shape[0] + q
    state[BUDGET] -= 1
    state[PIVOTS] += 1
    _touch(b, q, windows, seen, state)
    if closing == NONE:
        return _joined(a, b, q, pairs, frame, groups, max_rows)
    closed = np.zeros((0, 3), np.int64)
    found = info[key, 0] == 0
    if found:
        closed, total = _triangles(a, b, q, frame, groups)
        info[key, 0], info[key, 1], info[key, 2] = 1, min(total, max_rows + 1), total
        if fill[0] + len(closed) <= len(store):
            info[key, 0], info[key, 3], info[key, 4] = 2, fill[0], len(closed)
            store[fill[0]:fill[0] + len(closed)] = closed
            fill[0] += len(closed)
    n_ext, total = info[key, 1], info[key, 2]
    if state[BUDGET] <= 0 or total > max_rows or n_ext == 0 or (
            n_ext == 1 and closing == UNTIL_ONE):
        if total > max_rows or n_ext == 0:  # the chain leaves q out: no rows needed
            return closed[:0], total, pairs
        ext, _, pairs = _joined(a, b, q, pairs, frame, groups, max_rows)
        return ext, total, pairs
    state[BUDGET] -= 1
    state[PIVOTS] += 1
    _touch(q, a, windows, seen, state)
    if info[key, 0] == 2:
        return store[info[key, 3]:info[key, 3] + info[key, 4]], total, pairs
    if not found:
        closed, _ = _triangles(a, b, q, frame, groups)
    return closed, total, pairs


@njit(cache=True)
def _chain(order, frame, groups, memo, params):
    """Pivot from the pair (order[0], order[1]) through the other stars in turn: each new
    star q joins on (newest chain star, q), then the closing pairs (q, earlier chain star)
    narrow the rows (see ``params``' closing code); a star that leaves no row, or more
    than max_rows, is left out again. Returns (number of chain stars, chain stars, rows):
    0 stars when the chain gives no answer."""
    windows, seen, state = frame[0], frame[1], frame[2]
    max_skips, max_ambiguous, max_rows = params[0], params[1], params[2]
    a, b = order[0], order[1]
    _touch(a, b, windows, seen, state)
    state[BUDGET] -= 1
    cols = np.empty(len(order), np.int64)
    hyps = pairs = np.zeros((0, 2), np.int64)
    if windows[a, b, 1] <= windows[a, b, 0]:
        return 0, cols, hyps
    cols[0], cols[1] = a, b
    n_cols, skips = 2, 0
    for k in range(2, len(order)):
        q = order[k]
        if n_cols >= 3 and len(hyps) == 1:
            break
        if state[BUDGET] <= 0 or skips > max_skips:
            return 0, cols, hyps[:0]
        if n_cols == 2:
            rows, total, pairs = _pair_step(a, b, q, pairs, frame, groups, memo, params)
        else:
            rows, total = _pivot(hyps, cols, n_cols, q, frame, groups, params)
        if len(rows) == 0 or total > max_rows:
            skips += 1
            state[SKIPPED] += 1
            state[FIRST_EVENT] = state[FIRST_EVENT] or SKIPPED
            continue
        hyps = rows
        cols[n_cols] = q
        n_cols += 1
    if n_cols >= 3 and 1 <= len(hyps) <= max(max_ambiguous, 1):
        if len(hyps) > 1:
            state[AMBIGUOUS] += 1
            state[FIRST_EVENT] = state[FIRST_EVENT] or AMBIGUOUS
        return n_cols, cols, hyps
    return 0, cols, hyps[:0]


@njit(cache=True)
def next_chain(start, triples, first, windows, seen, state, pi, pj, groups, memo, params,
               screen):
    """From chain ``start`` on, the first chain that leaves an answer: (its index, chain
    stars, rows of stars (slots of ``pi``, ``pj``), one per hypothesis); the index is
    len(triples) when none is left or the lookup budget ``state[BUDGET]`` is spent. An
    answer is only its rows that pass verification's first test (``screen``: observed
    vectors, catalog vectors by slot, the test's cosine; below -1: no test;
    :func:`~startrack.matching.verify_kernels.fitting_rows`).

    Chain t starts from ``triples[t]`` and goes on with the stars below max(``first``,
    its faintest + 1) by brightness. ``windows`` (n x n x 2) holds each observed pair's
    table entries [start, stop); ``seen`` (n x n, bool) marks the pairs looked up so far;
    ``groups`` and ``memo`` are :func:`frame_arrays`'; ``params`` is (max_skips,
    max_ambiguous, max_rows, closing code). All but the first four carry over between
    calls.
    """
    frame = (windows, seen, state, pi, pj)
    order = np.empty(windows.shape[0], np.int64)
    for t in range(start, len(triples)):
        if state[BUDGET] <= 0:
            break
        state[CHAINS] = t + 1
        order[:3] = triples[t]
        m = 3
        for s in range(max(first, triples[t, 2] + 1)):
            if s != triples[t, 0] and s != triples[t, 1] and s != triples[t, 2]:
                order[m] = s
                m += 1
        n_cols, cols, rows = _chain(order[:m], frame, groups, memo, params)
        if n_cols:
            rows = fitting_rows(screen[0], cols[:n_cols], rows, screen[1], screen[2])
            if rows.shape[0]:
                return t, cols[:n_cols].copy(), rows.copy()
    return len(triples), order[:0].copy(), np.empty((0, 0), np.int64)
