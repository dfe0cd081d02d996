# The quad search's fast path (included by quad.pyx): the image's patterns of its
# brightest stars first, each candidate confirmed as soon as it is found, and the first
# one well confirmed returned at once, before any other pattern is looked up. A frame
# that has none falls back to match_window's ranking of every candidate.


cdef class QuadWindow:
    """One focal-length window of the search: the pattern edge limits (radians, as
    :func:`image_quads` takes them), the focal length the image vectors were made with
    (``f_mid``), the window's ends, and the confirmations that make a candidate strong."""
    cdef double max_edge, sparse_edge, f_mid, f_lo, f_hi
    cdef long long min_count

    def __init__(self, *, double max_edge, double sparse_edge, double f_mid, double f_lo,
                 double f_hi, long long min_count):
        self.max_edge, self.sparse_edge, self.f_mid = max_edge, sparse_edge, f_mid
        self.f_lo, self.f_hi, self.min_count = f_lo, f_hi, min_count


cdef class StrongMatch:
    """The first well-confirmed candidate: observation rows (4), catalog rows in matching
    order (4), its focal length, largest edge-ratio disagreement and confirmations."""
    cdef readonly object obs
    cdef readonly object cat
    cdef readonly double f_px
    cdef readonly double error
    cdef readonly long long confirmed


cdef void _row_edges(QuadRules rules, QuadTable table, const double[:, ::1] cat,
                     long long row, double *out) noexcept:
    """The six edge angles of table row ``row`` into ``out`` (libm's asin: within an ulp
    of :func:`_edges`, which the ranking uses, and no array per pattern)."""
    cdef long long a, b
    cdef double d0, d1, d2
    cdef int k
    for k in range(6):
        a, b = table.quads[row, rules.edges[k, 0]], table.quads[row, rules.edges[k, 1]]
        d0, d1, d2 = cat[a, 0] - cat[b, 0], cat[a, 1] - cat[b, 1], cat[a, 2] - cat[b, 2]
        out[k] = 2.0 * asin(min(max(sqrt(d0 * d0 + d1 * d1 + d2 * d2) / 2.0, 0.0), 1.0))


cdef StrongMatch _strong(const long long *obs4, const long long *cat4, double f,
                         double error, long long count):
    res = StrongMatch()
    res.obs, res.cat = np.empty(4, np.int64), np.empty(4, np.int64)
    cdef long long[::1] obs = res.obs
    cdef long long[::1] cat = res.cat
    cdef int k
    for k in range(4):
        obs[k], cat[k] = obs4[k], cat4[k]
    res.f_px, res.error, res.confirmed = f, error, count
    return res


cdef StrongMatch _pattern_strong(QuadTable table, QuadRules rules, QuadWindow window,
                                 const double[:, ::1] cat, const long long *obs4,
                                 const double *edges, Confirmer confirmer, _Ints rows):
    """The first strong candidate of image pattern ``obs4`` (its six ``edges``), its table
    rows in order; None if none is (``rows``: scratch)."""
    cdef double r[5]
    cdef double cat_edges[6]
    cdef long long lo[5]
    cdef long long hi[5]
    cdef long long cat4[4]
    cdef long long o, count
    cdef double least, f
    cdef Py_ssize_t p
    cdef int k
    _key_ranges(rules, edges, r, lo, hi)
    rows.n = 0
    _near_rows(table, rules, r, lo, hi, rows)
    for p in range(rows.n):
        _row_edges(rules, table, cat, rows.a[p], cat_edges)
        least = _best_order(rules, edges, cat_edges, &o)
        if least > rules.tolerance:
            continue
        f = window.f_mid * _scale(rules, edges, cat_edges, o)
        if not window.f_lo <= f <= window.f_hi:
            continue
        for k in range(4):
            cat4[k] = table.quads[rows.a[p], rules.perms[o, k]]
        count = confirmer.count(obs4, cat4, f)
        if count >= window.min_count:
            return _strong(obs4, cat4, f, least, count)
    return None


def first_confirmed(QuadTable table, QuadRules rules, QuadWindow window,
                    const double[:, ::1] cat, const double[:, ::1] vectors,
                    Confirmer confirmer):
    """The first candidate of ``window`` with at least ``min_count`` confirmations
    (:class:`Confirmer`), as a :class:`StrongMatch`, or None. Image patterns are taken
    by their faintest star (those of the 5 brightest stars first: each star's patterns
    made only when the brighter ones' have found nothing, in the order of
    :func:`image_quads_by_faintest`), each pattern's table rows in order, with the same
    key lookup, first test, best star order and tolerance as :func:`match_window`."""
    if table.keys.shape[0] == 0:
        return None
    stars = _image_stars(rules, vectors, window.max_edge, window.sparse_edge)
    if stars is None:
        return None
    cdef _Ints pats = _Ints(), rows = _Ints()
    cdef double edges[6]
    cdef Py_ssize_t d, i
    cdef StrongMatch found
    for d in range(3, stars.n):
        pats.n = 0
        _enumerate_ending(stars, d, pats)
        for i in range(0, pats.n, 4):
            _quad_edges(rules, stars, &pats.a[i], edges)
            found = _pattern_strong(table, rules, window, cat, &pats.a[i], edges, confirmer,
                                    rows)
            if found is not None:
                return found
    return None
