# The triangle search's state (included by triangles.pyx): the catalog table as the
# search reads it, the reusable memo memory, and one frame's search.


cdef class TriangleCatalog:
    """The catalog triangle table as the search reads it: areas (ascending) with their
    k-vector, polar moments, catalog rows (M x 3), and the catalog's unit vectors."""

    cdef const double[::1] area
    cdef const long long[::1] kk
    cdef double m, q
    cdef const double[::1] polar
    cdef const int[:, ::1] rows
    cdef const double[:, ::1] vectors

    def __init__(self, table, vectors):
        kv = table.kvector
        self.area = np.ascontiguousarray(kv.values, dtype=np.float64)
        self.kk = np.ascontiguousarray(kv.k, dtype=np.int64)
        self.m, self.q = float(kv.m), float(kv.q)
        self.polar = np.ascontiguousarray(table.polar, dtype=np.float64)
        self.rows = np.ascontiguousarray(table.rows, dtype=np.int32)
        self.vectors = np.ascontiguousarray(vectors, dtype=np.float64)


cdef class SearchBuffers:
    """The memo memory of a triangle search, kept for the next frame's: fresh memory
    costs a page fault per 4 kB touched, more than the lookups themselves on a junk
    frame. ``kept`` rows are (catalog rows x 3, sides x 3, handedness) of the triangles
    the polar filter kept; ``store`` rows the mapped catalog rows; ``scratch`` the polar
    filter's picks from one area window; ``picks`` and ``err`` the vertex mapping's of
    one lookup."""

    cdef readonly object kept, store, scratch, picks, err

    def __init__(self, Py_ssize_t rows=1 << 12):
        self.kept = np.empty((rows, KEPT_COLUMNS))
        self.store = np.empty((rows, 3), np.int64)
        self.scratch = np.empty(4 * rows, np.int64)
        self.picks, self.err = np.empty((3, rows), np.int64), np.empty(rows)

    @property
    def nbytes(self):
        """The bytes the arrays hold."""
        return sum(a.nbytes for a in (self.kept, self.store, self.scratch, self.picks,
                                      self.err))


cdef object _grown(object arr, Py_ssize_t fill, Py_ssize_t need):
    if fill + need <= arr.shape[0]:
        return arr
    grown = np.empty((max(2 * arr.shape[0], fill + need), arr.shape[1]), arr.dtype)
    grown[:fill] = arr[:fill]
    return grown


cdef class TriangleSearch:
    """One frame's triangle search over the observed stars ``vectors`` (n x 3) and their
    ``triples`` (T x 3, rows of ``vectors`` in search order): area and polar windows of
    ``tolerance_sigma`` sigmas, the features' sigmas propagated from the per-axis
    centroid ``sigma``, vertex mapping within ``side_tol``. ``buffers`` (a
    :class:`SearchBuffers`, as an earlier search left them) are reused. The counters
    (database candidates, triangles the polar filter kept, pivots, lookups) carry over
    between calls of :meth:`next_answer`."""

    cdef TriangleCatalog table
    cdef const double[:, ::1] vec
    cdef const long long[:, ::1] triples
    cdef double[:, ::1] feats  # (area, polar, sigma_area, sigma_polar) per triple
    cdef const long long[::1] lut  # triple code (a * n + b) * n + c -> row of triples
    cdef double k, side_tol, sigma
    cdef Py_ssize_t n, kept_fill, store_fill
    cdef long long[:, ::1] kept_info  # per sorted code: start, length, area window size
    cdef long long[:, ::1] info  # per ordered code: start, length in store
    cdef double[:, ::1] kept
    cdef long long[:, ::1] store
    cdef long long[::1] scratch
    cdef SearchBuffers memory
    cdef readonly long long candidates, polar_kept, pivots, lookups

    def __init__(self, TriangleCatalog table, vectors, triples, double tolerance_sigma,
                 double side_tol, double sigma, SearchBuffers buffers=None):
        self.table = table
        self.vec = np.ascontiguousarray(vectors, dtype=np.float64)
        tri = np.ascontiguousarray(triples, dtype=np.int64).reshape(-1, 3)
        self.triples = tri
        n = self.n = self.vec.shape[0]
        lut = np.full(n ** 3, -1, np.int64)
        lut[(tri[:, 0] * n + tri[:, 1]) * n + tri[:, 2]] = np.arange(len(tri))
        self.lut = lut
        self.feats = np.full((len(tri), 4), np.nan)
        self.k, self.side_tol, self.sigma = tolerance_sigma, side_tol, sigma
        self.kept_info = np.full((n ** 3, 3), -1, np.int64)
        self.info = np.full((n ** 3, 2), -1, np.int64)
        self.memory = SearchBuffers() if buffers is None else buffers
        self.kept, self.store = self.memory.kept, self.memory.store
        self.scratch = self.memory.scratch

    @property
    def buffers(self):
        """The memo memory as grown, for the next frame's search."""
        return self.memory

    def looked_up(self):
        """The ordered triples (a, b, c) looked up so far, by code (a * n + b) * n + c."""
        n = self.n
        codes = np.flatnonzero(np.asarray(self.info)[:, 0] >= 0)
        return [(int(c // (n * n)), int(c // n % n), int(c % n)) for c in codes]

    cdef void _keep(self, Py_ssize_t code) except *:
        """The polar-kept triangles of the sorted triple ``code``, into ``kept``."""
        cdef Py_ssize_t n = self.n, e, r, m = 0, fill = self.kept_fill, t = self.lut[code]
        cdef Features f = _features(&self.vec[code // (n * n), 0], &self.vec[code // n % n, 0],
                                    &self.vec[code % n, 0], self.sigma)
        self.feats[t, 0], self.feats[t, 1] = f.area, f.polar
        self.feats[t, 2], self.feats[t, 3] = f.sigma_area, f.sigma_polar
        cdef TriangleCatalog tab = self.table
        cdef Span span = kvector_range(tab.area, tab.kk, tab.m, tab.q,
                                       f.area - self.k * f.sigma_area,
                                       f.area + self.k * f.sigma_area)
        cdef double p_lo = f.polar - self.k * f.sigma_polar
        cdef double p_hi = f.polar + self.k * f.sigma_polar
        if span.stop - span.start > self.scratch.shape[0]:
            self.memory.scratch = np.empty(2 * (span.stop - span.start), np.int64)
            self.scratch = self.memory.scratch
        for e in range(span.start, span.stop):
            self.scratch[m] = e  # branch-free: the filter keeps a few percent, unpredictably
            m += (tab.polar[e] >= p_lo) & (tab.polar[e] <= p_hi)
        self.memory.kept = _grown(self.memory.kept, fill, m)
        self.kept = self.memory.kept
        cdef int i, j, l
        for r in range(m):
            i, j, l = tab.rows[self.scratch[r], 0], tab.rows[self.scratch[r], 1], \
                tab.rows[self.scratch[r], 2]
            self.kept[fill + r, 0], self.kept[fill + r, 1], self.kept[fill + r, 2] = i, j, l
            _describe(&tab.vectors[i, 0], &tab.vectors[j, 0], &tab.vectors[l, 0],
                      &self.kept[fill + r, SIDES])
        self.kept_info[code, 0], self.kept_info[code, 1] = fill, m
        self.kept_info[code, 2] = span.stop - span.start
        self.kept_fill = fill + m

    cdef Span _lookup(self, long long a, long long b, long long c) except *:
        """The catalog triangles of the observed triple (a, b, c), as rows of ``store``:
        catalog stars in its vertex order, best side agreement first; worked out (and
        counted) once per frame and vertex order."""
        cdef Py_ssize_t n = self.n, code = (a * n + b) * n + c
        cdef long long lo = min(a, b, c), hi = max(a, b, c)
        cdef Py_ssize_t key = (lo * n + (a + b + c - lo - hi)) * n + hi, s0, m, r, e, v
        cdef Span span
        if self.info[code, 0] < 0:
            if self.kept_info[key, 0] < 0:
                self._keep(key)
            s0, m = self.kept_info[key, 0], self.kept_info[key, 1]
            if 6 * m > self.memory.err.shape[0]:
                self.memory.picks = np.empty((3, 12 * m), np.int64)
                self.memory.err = np.empty(12 * m)
            # the mirror is refused unless the triangle is too flat to tell
            count = _map_sides(&self.vec[a, 0], &self.vec[b, 0], &self.vec[c, 0], self.kept,
                               s0, m, self.side_tol, self.feats[self.lut[key], 0]
                               > self.k * self.feats[self.lut[key], 2], self.memory.picks,
                               self.memory.err)
            self._store(s0, count, self.memory.picks)
            self.info[code, 0], self.info[code, 1] = self.store_fill - count, count
            self.candidates += self.kept_info[key, 2]
            self.polar_kept += m
            self.lookups += 1
        span.start = self.info[code, 0]
        span.stop = span.start + self.info[code, 1]
        return span

    cdef void _store(self, Py_ssize_t s0, Py_ssize_t count,
                     const long long[:, ::1] picks) except *:
        """The mapped catalog rows of a lookup, in rank order, appended to ``store``."""
        cdef Py_ssize_t fill = self.store_fill, r, e, v
        self.memory.store = _grown(self.memory.store, fill, count)
        self.store = self.memory.store
        for r in range(count):  # picks: candidate, vertex order, rank
            e = picks[2, r]
            for v in range(3):
                self.store[fill + r, v] = <long long>self.kept[s0 + picks[0, e],
                                                               _PERMS[3 * picks[1, e] + v]]
        self.store_fill = fill + count

    cdef tuple _pivots(self, hyps, long long[::1] stars, Py_ssize_t min_stars,
                       bint pivot_first):
        """Pivot from the triple in ``stars[:3]`` while more than one row is left or
        fewer than ``min_stars`` stars are in: a triangle (newest two chain stars, or the
        first triangle's last two when ``pivot_first``, and a new star in index order)
        joined on the shared two. Returns (rows, chain stars)."""
        cdef Py_ssize_t n_stars = 3, cp = 1, cq = 2, extra
        cdef Span span
        cdef bint found
        while hyps.shape[0] > 1 or n_stars < min_stars:
            found = False
            for extra in range(self.n):
                if _holds(stars, n_stars, extra):
                    continue
                self.pivots += 1
                span = self._lookup(stars[cp], stars[cq], extra)
                joined = _join_pivot(hyps, cp, cq, self.store[span.start:span.stop])
                if joined.shape[0]:
                    hyps = joined
                    stars[n_stars] = extra
                    if not pivot_first:
                        cp, cq = cq, n_stars
                    n_stars += 1
                    found = True
                    break
            if not found:
                break  # stars ran out: the survivors go to verification
        return hyps, n_stars

    def next_answer(self, Py_ssize_t start, Py_ssize_t min_stars, Py_ssize_t max_ambiguous,
                    bint pivot_first=False):
        """From triple ``start`` on, the first whose lookup leaves catalog triangles: (its
        index, chain stars, at most ``max_ambiguous`` rows of catalog stars after the
        pivots); the index is the number of triples when none is left. ``pivot_first``:
        every pivot triangle shares two stars with the first one (the 2011 paper)."""
        stars_arr = np.empty(self.n, np.int64)
        cdef long long[::1] stars = stars_arr
        cdef Py_ssize_t t, n_triples = self.triples.shape[0]
        cdef Span span
        for t in range(start, n_triples):
            span = self._lookup(self.triples[t, 0], self.triples[t, 1], self.triples[t, 2])
            if span.stop == span.start:
                continue  # a false star, or a star outside the pattern set
            stars[0], stars[1], stars[2] = self.triples[t, 0], self.triples[t, 1], \
                self.triples[t, 2]
            hyps = np.asarray(self.store[span.start:span.stop]).copy()
            hyps, n_stars = self._pivots(hyps, stars, min_stars, pivot_first)
            return t, stars_arr[:n_stars].copy(), hyps[:max_ambiguous].copy()
        return n_triples, stars_arr[:0].copy(), np.empty((0, 3), np.int64)
