"""The angle method's lost-in-space search with pivoting: chains of pair lookups and
joins, each from one star triple through the other stars in turn (see
:mod:`startrack.matchers._angle` for the method), in one call per answer.

The lookups are the observed pairs' windows in the pair table; the joins are
:mod:`startrack._core.database.pair_tables`', each over a pair window grouped once per frame.
:func:`next_chain` returns at each chain that leaves an answer (screened by
verification's first test), so that verification's first acceptance ends the search; an
:class:`AngleFrame` carries its counters, groupings and kept triangles between calls.
"""

import numpy as np

from startrack._core.verify.verification cimport fits_within
from startrack._core._wahba cimport wahba
from startrack._core.database.pair_tables cimport group_window, join_close_rows, join_extend_rows, linked

#: ``AngleLimits.closing`` codes, in the order of :data:`startrack.matchers._angle.CLOSING`.
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


include "angle_steps.pxi"


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


cdef object _fitting_rows(AngleFrame f, const long long[::1] cols, object rows):
    """The hypotheses (``rows``, slots of the chain stars ``cols``) that pass
    verification's first test (every pair within the match radius of the other at their
    Wahba fit); all of them when there is no test."""
    if f.cos_radius < -1.0:
        return rows
    cdef const long long[:, :] slots = rows
    keep = np.zeros(slots.shape[0], np.bool_)
    cdef unsigned char[::1] mark = keep.view(np.uint8)
    cdef double[:, ::1] cam = np.empty((cols.shape[0], 3)), sky = np.empty((cols.shape[0], 3))
    cdef double[:, ::1] rot = np.empty((3, 3))
    cdef Py_ssize_t h, k
    cdef int i
    for h in range(slots.shape[0]):
        for k in range(cols.shape[0]):
            for i in range(3):
                cam[k, i] = f.obs_vectors[cols[k], i]
                sky[k, i] = f.slot_vectors[slots[h, k], i]
        wahba(cam, sky, rot)
        mark[h] = fits_within(cam, sky, rot, f.cos_radius)
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
