"""The angle method's lost-in-space search with pivoting: chains of pair lookups and
joins, each from one star triple through the other stars in turn (see
:mod:`startrack.matchers.angle` for the method), in one call per answer.

The lookups are the observed pairs' windows in the pair table; the joins are
:mod:`startrack._core.pairs`', each over a pair window grouped once per frame.
:func:`next_chain` returns at each chain that leaves an answer (screened by
verification's first test), so that verification's first acceptance ends the search; an
:class:`AngleFrame` carries its counters, groupings and kept triangles between calls.
"""

import numpy as np

from startrack._core._wahba cimport wahba
from startrack._core.pairs cimport group_window, join_close_rows, join_extend_rows, linked

#: ``AngleLimits.closing`` codes, in the order of :data:`startrack.matchers.angle.CLOSING`.
UNTIL_ONE, ALL, NONE = range(3)
cdef enum:
    _UNTIL_ONE = 0
    _NONE = 2
    # A frame keeps at most this many triangles of its first pairs, for the chains that
    # share them.
    STORE_ROWS = 1 << 14


cdef class AngleLimits:
    """A matcher's limits: stars one chain may leave out, hypotheses an answer may hold,
    rows a chain may grow to, the closing rule (:data:`UNTIL_ONE`, :data:`ALL`,
    :data:`NONE`) and the pair steps a frame may take."""

    cdef readonly Py_ssize_t max_skips, max_ambiguous, max_rows, max_lookups
    cdef readonly int closing

    def __init__(self, Py_ssize_t max_skips, Py_ssize_t max_ambiguous, Py_ssize_t max_rows,
                 int closing, Py_ssize_t max_lookups):
        self.max_skips, self.max_ambiguous, self.max_rows = max_skips, max_ambiguous, max_rows
        self.closing, self.max_lookups = closing, max_lookups


cdef class AngleFrame:
    """One frame's search state: each observed pair's table entries [start, stop)
    (``windows``, n x n x 2), the pair table's stars as slots (``pi``, ``pj``), the
    observed and slot vectors and the cosine of verification's first test (below -1: no
    test), with the pairs looked up so far, their groupings (built on first use) and the
    triangles of the first pairs. The counters say what the search did: ``chains`` (the
    last started, 1-based), ``pivots``, ``candidates`` (database pairs of the first
    lookups), ``lookups``, ``skipped`` stars, ``ambiguous`` answers, and whether the
    first of those two events was an ambiguous answer (``ambiguous_first``)."""

    cdef AngleLimits limits
    cdef const long long[:, :, ::1] windows
    cdef const int[::1] pi, pj
    cdef const double[:, ::1] obs_vectors, slot_vectors
    cdef double cos_radius
    cdef Py_ssize_t n
    cdef unsigned char[:, ::1] seen
    cdef int[:, ::1] heads
    cdef int[::1] nxt, val
    cdef long long[::1] offsets
    cdef unsigned char[::1] done
    cdef long long[:, ::1] info
    cdef object store
    cdef Py_ssize_t fill
    cdef readonly long long budget, chains, pivots, candidates, lookups, skipped, ambiguous
    cdef readonly bint ambiguous_first
    cdef bint any_event

    def __init__(self, AngleLimits limits, windows, pi, pj, obs_vectors, slot_vectors,
                 double cos_radius):
        self.limits, self.windows, self.pi, self.pj = limits, windows, pi, pj
        self.obs_vectors = np.ascontiguousarray(obs_vectors, dtype=np.float64)
        self.slot_vectors, self.cos_radius = slot_vectors, cos_radius
        n = self.n = self.windows.shape[0]
        self.budget = limits.max_lookups
        self.seen = np.zeros((n, n), np.uint8)
        # Each ordered observed pair (p, q) gets a row of ``heads`` and the stretch of
        # ``nxt`` and ``val`` from ``offsets[p * n + q]``, filled when first asked for.
        sizes = 2 * (np.asarray(windows)[..., 1] - np.asarray(windows)[..., 0]).clip(0)
        np.fill_diagonal(sizes, 0)
        offsets = np.concatenate([[0], np.cumsum(sizes.ravel())]).astype(np.int64)
        self.offsets = offsets
        self.heads = np.empty((n * n, self.slot_vectors.shape[0]), np.int32)
        self.nxt = np.empty(offsets[n * n], np.int32)
        self.val = np.empty(offsets[n * n], np.int32)
        self.done = np.zeros(n * n, np.uint8)
        # Each ordered triple (a, b, q): status (0 none, 1 counted, 2 rows kept), joined
        # rows, total, start and length in ``store``.
        self.info = np.zeros((n ** 3, 5), np.int64)
        self.store = np.empty((STORE_ROWS, 3), np.int64)


cdef inline void _touch(AngleFrame f, Py_ssize_t p, Py_ssize_t q) noexcept:
    """Count the first lookup of the observed pair {p, q} as database candidates."""
    cdef Py_ssize_t a = min(p, q), b = max(p, q)
    if not f.seen[a, b]:
        f.seen[a, b] = True
        f.candidates += f.windows[p, q, 1] - f.windows[p, q, 0]
        f.lookups += 1


cdef inline bint _empty(AngleFrame f, Py_ssize_t p, Py_ssize_t q) noexcept:
    return f.windows[p, q, 1] <= f.windows[p, q, 0]


cdef inline void _event(AngleFrame f, bint ambiguous) noexcept:
    if not f.any_event:
        f.any_event, f.ambiguous_first = True, ambiguous


cdef object _first_pairs(AngleFrame f, Py_ssize_t p, Py_ssize_t q):
    """The catalog pairs of (p, q) as rows (star of p, star of q): the window in table
    order one way round, then the other."""
    cdef Py_ssize_t s0 = f.windows[p, q, 0], s1 = f.windows[p, q, 1], w = max(s1 - s0, 0), e
    out = np.empty((2 * w, 2), np.int64)
    cdef long long[:, ::1] rows = out
    cdef long long i, j
    for e in range(s0, s1):
        if p > q:
            i, j = f.pj[e], f.pi[e]
        else:
            i, j = f.pi[e], f.pj[e]
        rows[e - s0, 0], rows[e - s0, 1] = i, j
        rows[w + e - s0, 0], rows[w + e - s0, 1] = j, i
    return out


cdef Py_ssize_t _grouped(AngleFrame f, Py_ssize_t p, Py_ssize_t q) noexcept:
    """The window of (p, q) grouped per star of p (group_window), built once per frame:
    its key into ``heads`` and ``offsets``."""
    cdef Py_ssize_t k = p * f.n + q, o0 = f.offsets[k], o1 = f.offsets[k + 1]
    if not f.done[k]:
        f.done[k] = True
        f.heads[k, :] = -1
        group_window(f.pi, f.pj, f.windows[p, q, 0], f.windows[p, q, 1], p > q, f.heads[k],
                     f.nxt[o0:o1], f.val[o0:o1])
    return k


cdef tuple _extend(AngleFrame f, const long long[:, :] hyps, Py_ssize_t col, Py_ssize_t p,
                   Py_ssize_t q, Py_ssize_t max_rows):
    """join_extend on the window of (p, q): (rows, total)."""
    _touch(f, p, q)
    if _empty(f, p, q):
        return np.zeros((0, hyps.shape[1] + 1), np.int64), 0
    cdef Py_ssize_t k = _grouped(f, p, q), o0 = f.offsets[k], o1 = f.offsets[k + 1]
    return join_extend_rows(hyps, col, f.heads[k], f.nxt[o0:o1], f.val[o0:o1], max_rows)


cdef object _close(AngleFrame f, object hyps, Py_ssize_t col_p, Py_ssize_t col_q,
                   Py_ssize_t p, Py_ssize_t q):
    """join_close on the window of (p, q): the same pair set either way round, so an
    existing grouping of (q, p) serves."""
    _touch(f, p, q)
    if _empty(f, p, q):
        return hyps[:0]
    if f.done[q * f.n + p]:
        p, q = q, p
    cdef Py_ssize_t k = _grouped(f, p, q), o0 = f.offsets[k], o1 = f.offsets[k + 1]
    return join_close_rows(hyps, col_p, col_q, f.heads[k], f.nxt[o0:o1], f.val[o0:o1])


cdef bint _stops(AngleFrame f, long long total, Py_ssize_t n_rows) noexcept:
    """Whether a pivot's closing pairs stop here: budget spent, too many or no rows, or
    one row left and the rule is to close until one is."""
    return f.budget <= 0 or total > f.limits.max_rows or n_rows == 0 or (
        n_rows == 1 and f.limits.closing == _UNTIL_ONE)


cdef tuple _pivot(AngleFrame f, object hyps, const long long[::1] cols, Py_ssize_t n_cols,
                  Py_ssize_t q):
    """One pivot to star q: the join on (newest chain star, q), then the closing pairs (q,
    earlier chain star) while the closing rule asks for them. (rows, total)."""
    f.budget -= 1
    f.pivots += 1
    rows, total = _extend(f, hyps, n_cols - 1, cols[n_cols - 1], q, f.limits.max_rows + 1)
    cdef Py_ssize_t col_t
    for col_t in range(n_cols - 1 if f.limits.closing != _NONE else 0):
        if _stops(f, total, len(rows)):
            break
        f.budget -= 1
        f.pivots += 1
        rows = _close(f, rows, n_cols, col_t, q, cols[col_t])
    return rows, total


cdef tuple _joined(AngleFrame f, Py_ssize_t a, Py_ssize_t b, Py_ssize_t q, object pairs):
    """The pair rows of (a, b) (built if ``pairs`` is still None) joined on (b, q):
    (rows, total, pairs)."""
    if pairs is None:
        pairs = _first_pairs(f, a, b)
    rows, total = _extend(f, pairs, 1, b, q, f.limits.max_rows + 1)
    return rows, total, pairs


cdef tuple _triangles(AngleFrame f, Py_ssize_t a, Py_ssize_t b, Py_ssize_t q):
    """The pair rows of (a, b) joined on (b, q) and narrowed by (q, a) without the rows
    in between: (rows, rows joined on (b, q)). Counts nothing."""
    if _empty(f, b, q):
        return np.empty((0, 3), np.int64), 0
    cdef Py_ssize_t k = _grouped(f, b, q), o0 = f.offsets[k], o1 = f.offsets[k + 1], kc
    cdef int[::1] head = f.heads[k], nxt = f.nxt[o0:o1], val = f.val[o0:o1]
    cdef int[::1] c_head = head, c_nxt = nxt, c_val = val
    cdef bint closes = not _empty(f, q, a)
    if closes:
        kc = _grouped(f, a, q) if f.done[a * f.n + q] else _grouped(f, q, a)
        c_head, c_nxt = f.heads[kc], f.nxt[f.offsets[kc]:f.offsets[kc + 1]]
        c_val = f.val[f.offsets[kc]:f.offsets[kc + 1]]
    out = np.empty((16, 3), np.int64)
    cdef long long[:, ::1] rows = out
    cdef Py_ssize_t m = 0, total = 0, e, p
    cdef int half, x, y, z
    for half in range(2):  # _first_pairs' order
        for e in range(f.windows[a, b, 0], f.windows[a, b, 1]):
            if (a > b) == (half == 0):
                x, y = f.pj[e], f.pi[e]
            else:
                x, y = f.pi[e], f.pj[e]
            p = head[y]
            while p >= 0:
                z = val[p]
                p = nxt[p]
                if z == x or z == y:
                    continue
                total += 1
                if closes and linked(c_head, c_nxt, c_val, z, x):
                    if m == rows.shape[0]:
                        out = np.concatenate((out, np.empty_like(out)))
                        rows = out
                    rows[m, 0], rows[m, 1], rows[m, 2] = x, y, z
                    m += 1
    return out[:m], total


cdef tuple _pair_step(AngleFrame f, Py_ssize_t a, Py_ssize_t b, Py_ssize_t q, object pairs):
    """:func:`_pivot` from the chain's first pair (a, b) to q: the triangles (a, b, q),
    which the chains that share a first pair ask for again and again. Their counts, and
    their rows while they fit into the frame's store, are kept for the frame; the
    counters advance as if each were found anew. ``pairs`` are the pair rows, None until
    a pivot needs them. Returns (rows, total, pairs)."""
    cdef Py_ssize_t key = (a * f.n + b) * f.n + q, max_rows = f.limits.max_rows
    f.budget -= 1
    f.pivots += 1
    _touch(f, b, q)
    if f.limits.closing == _NONE:
        return _joined(f, a, b, q, pairs)
    closed = np.zeros((0, 3), np.int64)
    cdef bint found = f.info[key, 0] == 0
    if found:
        closed, total = _triangles(f, a, b, q)
        f.info[key, 0], f.info[key, 1], f.info[key, 2] = 1, min(total, max_rows + 1), total
        if f.fill + len(closed) <= STORE_ROWS:
            f.info[key, 0], f.info[key, 3], f.info[key, 4] = 2, f.fill, len(closed)
            f.store[f.fill:f.fill + len(closed)] = closed
            f.fill += len(closed)
    cdef long long n_ext = f.info[key, 1]
    total = f.info[key, 2]
    if _stops(f, total, n_ext):
        if total > max_rows or n_ext == 0:  # the chain leaves q out: no rows needed
            return closed[:0], total, pairs
        ext, _, pairs = _joined(f, a, b, q, pairs)
        return ext, total, pairs
    f.budget -= 1
    f.pivots += 1
    _touch(f, q, a)
    if f.info[key, 0] == 2:
        return f.store[f.info[key, 3]:f.info[key, 3] + f.info[key, 4]], total, pairs
    if not found:
        closed, _ = _triangles(f, a, b, q)
    return closed, total, pairs


cdef tuple _chain(AngleFrame f, const long long[::1] order):
    """Pivot from the pair (order[0], order[1]) through the other stars in turn: each new
    star q joins on (newest chain star, q), then the closing pairs (q, earlier chain star)
    narrow the rows; a star that leaves no row, or more than max_rows, is left out again.
    Returns (number of chain stars, chain stars, rows): 0 stars when the chain gives no
    answer."""
    cdef Py_ssize_t a = order[0], b = order[1], n_cols = 2, skips = 0, k, q
    _touch(f, a, b)
    f.budget -= 1
    cols = np.empty(order.shape[0], np.int64)
    cdef long long[::1] chain = cols
    hyps, pairs = np.zeros((0, 2), np.int64), None
    if _empty(f, a, b):
        return 0, cols, hyps
    chain[0], chain[1] = a, b
    for k in range(2, order.shape[0]):
        q = order[k]
        if n_cols >= 3 and len(hyps) == 1:
            break
        if f.budget <= 0 or skips > f.limits.max_skips:
            return 0, cols, hyps[:0]
        if n_cols == 2:
            rows, total, pairs = _pair_step(f, a, b, q, pairs)
        else:
            rows, total = _pivot(f, hyps, chain, n_cols, q)
        if len(rows) == 0 or total > f.limits.max_rows:
            skips += 1
            f.skipped += 1
            _event(f, False)
            continue
        hyps = rows
        chain[n_cols] = q
        n_cols += 1
    if n_cols >= 3 and 1 <= len(hyps) <= max(f.limits.max_ambiguous, 1):
        if len(hyps) > 1:
            f.ambiguous += 1
            _event(f, True)
        return n_cols, cols, hyps
    return 0, cols, hyps[:0]


cdef bint _fits(AngleFrame f, const long long[::1] hyp_obs, const long long[:, :] rows,
                Py_ssize_t h, double[:, ::1] cam, double[:, ::1] sky,
                double[:, ::1] rot) noexcept:
    """Verification's first test of hypothesis h: whether every pair lies within the
    match radius of the other at their Wahba fit."""
    cdef Py_ssize_t k, i
    cdef double dot
    for k in range(hyp_obs.shape[0]):
        for i in range(3):
            cam[k, i] = f.obs_vectors[hyp_obs[k], i]
            sky[k, i] = f.slot_vectors[rows[h, k], i]
    wahba(cam, sky, rot)
    for k in range(hyp_obs.shape[0]):
        dot = 0.0
        for i in range(3):
            dot += (rot[i, 0] * cam[k, 0] + rot[i, 1] * cam[k, 1]
                    + rot[i, 2] * cam[k, 2]) * sky[k, i]
        if dot < f.cos_radius:
            return False
    return True


cdef object _fitting_rows(AngleFrame f, object cols, object rows):
    """The hypotheses (``rows``, slots of the chain stars ``cols``) that pass
    verification's first test; all of them when there is no test."""
    if f.cos_radius < -1.0:
        return rows
    keep = np.zeros(len(rows), np.bool_)
    cdef unsigned char[::1] mark = keep.view(np.uint8)
    cdef double[:, ::1] cam = np.empty((len(cols), 3)), sky = np.empty((len(cols), 3))
    cdef double[:, ::1] rot = np.empty((3, 3))
    cdef Py_ssize_t h
    for h in range(len(rows)):
        mark[h] = _fits(f, cols, rows, h, cam, sky, rot)
    return rows[keep]


def next_chain(AngleFrame frame, const long long[:, ::1] triples, Py_ssize_t start,
               Py_ssize_t first):
    """From chain ``start`` on, the first chain that leaves an answer: (its index, chain
    stars, rows of slots, one per hypothesis); the index is len(triples) when none is
    left or the frame's lookup budget is spent. An answer is only its rows that pass
    verification's first test. Chain t starts from ``triples[t]`` and goes on with the
    stars below max(``first``, its faintest + 1) by brightness."""
    cdef AngleFrame f = frame
    order = np.empty(f.n, np.int64)
    cdef long long[::1] stars = order
    cdef Py_ssize_t t, m, s
    for t in range(start, triples.shape[0]):
        if f.budget <= 0:
            break
        f.chains = t + 1
        stars[0], stars[1], stars[2] = triples[t, 0], triples[t, 1], triples[t, 2]
        m = 3
        for s in range(max(first, triples[t, 2] + 1)):
            if s != triples[t, 0] and s != triples[t, 1] and s != triples[t, 2]:
                stars[m] = s
                m += 1
        n_cols, cols, rows = _chain(f, stars[:m])
        if n_cols:
            rows = _fitting_rows(f, cols[:n_cols], rows)
            if len(rows):
                return t, cols[:n_cols].copy(), rows.copy()
    return triples.shape[0], order[:0].copy(), np.empty((0, 0), np.int64)
