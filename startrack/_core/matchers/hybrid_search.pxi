# The hybrid search over one pass's shortlists (included by hybrid.pyx).


cdef class HybridSearch:
    """One pass of the hybrid search: the observed triples of ``frame`` in turn, their
    catalog triangles among the shortlisted ``pairs`` (a :class:`ShortPairs`), each
    confirmed by a fourth observed star whose angles match, within the frame's tolerance,
    on a star of ``shortlist`` (n x catalog) in the pair table's ``neighbours``.
    ``catalog`` holds the catalog's unit vectors; ``heads``, over the catalog, is all -1
    and left so. At most ``keep_n`` triangles of a triple go to the fourth-star check;
    the ``max_unconfirmed`` best of those none confirms are kept (:attr:`best_rows`).
    The counters carry over between calls."""

    cdef HybridFrame frame
    cdef ShortPairs pairs
    cdef const unsigned char[:, ::1] short
    cdef const double[:, ::1] cat
    cdef PairNeighbours neighbours
    cdef long long[::1] heads, buf, side, nxt
    cdef object rows_buf, err_buf  # the triangles of one triple, grown as needed
    cdef long long[:, ::1] rows
    cdef double[::1] err
    cdef Py_ssize_t keep_n
    cdef long long[:, ::1] best_rows_v
    cdef double[::1] best_err_v
    cdef readonly object best_rows, best_err
    cdef readonly long long tested, fourth_tried, best_kept

    def __init__(self, HybridFrame frame, ShortPairs pairs, shortlist, catalog,
                 PairNeighbours neighbours, heads, Py_ssize_t keep_n,
                 Py_ssize_t max_unconfirmed):
        self.frame, self.pairs, self.neighbours = frame, pairs, neighbours
        self.short = np.ascontiguousarray(shortlist, dtype=np.bool_).view(np.uint8)
        self.cat = np.ascontiguousarray(catalog, dtype=np.float64)
        self.heads, self.keep_n = heads, keep_n
        self.buf, self.side = np.empty(4096, np.int64), np.empty(4096, np.int64)
        self.nxt = np.empty(1024, np.int64)
        self.rows_buf, self.err_buf = np.empty((64, 3), np.int64), np.empty(64)
        self.rows, self.err = self.rows_buf, self.err_buf
        self.best_rows = np.empty((max(max_unconfirmed, 0), 6), np.int64)
        self.best_err = np.empty(max(max_unconfirmed, 0))
        self.best_rows_v, self.best_err_v = self.best_rows, self.best_err

    def triangles(self, Py_ssize_t t):
        """Triplets (x, y, z), x != z: (x, y) a pair of observed pair (a, b) and (y, z)
        one of (b, c), (a, b, c) the triple ``t``, whose area and polar moment lie within
        the windows of its features and, unless its hand is 0, whose handedness is its
        hand. Rows in the order of the (x, y) pairs, then of y's pairs in (b, c).
        Returns (rows, err in sigmas); :attr:`tested` counts the triplets tested."""
        cdef Py_ssize_t m = self._triangles(t)
        return self.rows_buf[:m].copy(), self.err_buf[:m].copy()

    cdef Py_ssize_t _triangles(self, Py_ssize_t t) except -1:
        """:meth:`triangles` into ``rows`` and ``err``; returns how many."""
        cdef Py_ssize_t n = self.pairs.n, ab, bc, s0, s1, p, q, m = 0
        cdef const long long[:, ::1] tri = self.frame.triples
        ab, bc = tri[t, 0] * n + tri[t, 1], tri[t, 1] * n + tri[t, 2]
        cdef const long long[::1] start = self.pairs.start_v, xs = self.pairs.xs_v
        cdef const long long[::1] ys = self.pairs.ys_v
        s0, s1 = start[bc], start[bc + 1]
        if s1 - s0 > self.nxt.shape[0]:
            self.nxt = np.empty(2 * (s1 - s0), np.int64)
        for p in range(s1 - 1, s0 - 1, -1):  # linked backwards: partners come out forwards
            self.nxt[p - s0] = self.heads[xs[p]]
            self.heads[xs[p]] = p
        cdef long long x, y, z
        cdef double e
        try:
            for q in range(start[ab], start[ab + 1]):
                x, y = xs[q], ys[q]
                p = self.heads[y]
                while p >= 0:
                    z = ys[p]
                    p = self.nxt[p - s0]
                    if z == x:
                        continue
                    self.tested += 1
                    e = _feature_test(self.cat, x, y, z, &self.frame.feats[t, 0],
                                      self.frame.k, self.frame.hands[t])
                    if e < 0:
                        continue
                    if m == self.rows.shape[0]:
                        self.rows_buf = np.concatenate((self.rows_buf, self.rows_buf))
                        self.err_buf = np.concatenate((self.err_buf, self.err_buf))
                        self.rows, self.err = self.rows_buf, self.err_buf
                    self.rows[m, 0], self.rows[m, 1], self.rows[m, 2] = x, y, z
                    self.err[m] = e
                    m += 1
        finally:
            for p in range(s0, s1):
                self.heads[xs[p]] = -1
        return m

    def next_triangles(self, Py_ssize_t start):
        """The first triple, from index ``start`` on, with catalog triangles among the
        shortlisted pairs: (its index, rows, err); the index is the number of triples
        when none is left."""
        cdef Py_ssize_t t, m, n_triples = self.frame.triples.shape[0]
        for t in range(start, n_triples):
            m = self._triangles(t)
            if m:
                return t, self.rows_buf[:m].copy(), self.err_buf[:m].copy()
        return n_triples, np.empty((0, 3), np.int64), np.empty(0)

    cdef bint _has_partner(self, long long star, long long other, double lo,
                           double hi) noexcept nogil:
        cdef Py_ssize_t n = partners(self.neighbours, star, lo, hi, False, self.buf), q
        for q in range(min(n, self.buf.shape[0])):
            if self.buf[q] == other:
                return True
        return False

    cdef object _confirm(self, const long long[:, ::1] trip, const long long[::1] abc,
                         Py_ssize_t d):
        """The candidates (rows of ``trip``, catalog stars for the observed a, b, c) that
        the fourth observed star d confirms, as rows (a, b, c, w): w a shortlisted star
        of d whose pair angles to the three catalog stars match d's to a, b and c."""
        cdef const double[:, ::1] ang = self.frame.ang
        cdef double tol = self.frame.tol
        cdef long long a = abc[0], b = abc[1], c = abc[2], w
        cdef Py_ssize_t k, q, n_w
        hits = []
        for k in range(trip.shape[0]):
            n_w = partners(self.neighbours, trip[k, 0], ang[a, d] - tol, ang[a, d] + tol,
                           a > d, self.side)
            for q in range(min(n_w, self.side.shape[0])):
                w = self.side[q]
                if not self.short[d, w]:
                    continue
                if not self._has_partner(trip[k, 1], w, ang[b, d] - tol, ang[b, d] + tol):
                    continue
                if not self._has_partner(trip[k, 2], w, ang[c, d] - tol, ang[c, d] + tol):
                    continue
                hits.append((trip[k, 0], trip[k, 1], trip[k, 2], w))
        return np.array(hits, np.int64).reshape(-1, 4)

    def next_confirmed(self, Py_ssize_t start):
        """From triple index ``start`` on, the first triple whose ``keep_n`` best catalog
        triangles a fourth observed star d confirms (the stars d in turn): (its index, d,
        rows of catalog stars for (a, b, c, d)); index the number of triples when none is
        left. Triangles no star confirms go to the best so far."""
        cdef const long long[:, ::1] tri = self.frame.triples
        cdef Py_ssize_t t, d, r, m, n = self.short.shape[0]
        for t in range(start, tri.shape[0]):
            m = self._triangles(t)
            if m == 0:
                continue
            rows, err = self.rows_buf[:m].copy(), self.err_buf[:m].copy()
            order = np.arange(rows.shape[0], dtype=np.int64)
            _stable_order(order, err.copy())
            keep = order[:self.keep_n]
            trip = rows[keep]
            for d in range(n):
                if d == tri[t, 0] or d == tri[t, 1] or d == tri[t, 2]:
                    continue
                self.fourth_tried += 1
                hits = self._confirm(trip, tri[t], d)
                if hits.shape[0]:
                    return t, d, hits
            for r in range(keep.shape[0]):
                self.best_kept = _keep_best(self.best_rows_v, self.best_err_v,
                                            self.best_kept, tri[t], trip[r], err[keep[r]])
        return tri.shape[0], -1, np.empty((0, 4), np.int64)


cdef void _stable_order(long long[::1] order, double[::1] key) except *:
    if order.shape[0] and merge_sort(&order[0], &key[0], 0, order.shape[0]) < 0:
        raise MemoryError("hybrid search: no memory to sort a triple's triangles")
