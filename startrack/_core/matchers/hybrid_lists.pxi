# The hybrid search's pair lists (included by hybrid.pyx): the angle votes, and each
# observed pair's catalog pairs among the shortlisted stars (the table's neighbour lists
# are startrack._core.database.pair_tables.PairNeighbours).


def angle_votes(const int[::1] pi, const int[::1] pj, const long long[:, :, ::1] windows,
                Py_ssize_t n_catalog):
    """Votes (n x catalog rows, int16): in how many of observed star a's pair windows each
    catalog star appears, once per window however many of its pairs it is in.
    ``windows`` (n x n x 2) holds each observed pair's table entries [start, stop)."""
    cdef Py_ssize_t n = windows.shape[0], a, b, e, h
    votes_arr = np.zeros((n, n_catalog), np.int16)
    stamp_arr = np.full(n_catalog, -1, np.int64)
    cdef short[:, ::1] votes = votes_arr
    cdef long long[::1] stamp = stamp_arr
    cdef long long key, x
    for a in range(n):
        for b in range(a + 1, n):
            key = a * n + b
            for e in range(windows[a, b, 0], windows[a, b, 1]):
                for h in range(2):
                    x = pi[e] if h == 0 else pj[e]
                    if stamp[x] != key:
                        stamp[x] = key
                        votes[a, x] += 1
                        votes[b, x] += 1
    return votes_arr


cdef class ShortPairs:
    """Each observed pair's catalog pairs among the shortlisted stars: for a < b, the
    pairs (xs[p], ys[p]), p in [start[a*n + b], start[a*n + b + 1]), are the entries of
    the window ``windows[a, b]`` seen both ways round, x shortlisted for a and y for b:
    first every entry as (i, j), in table order, then every entry as (j, i)."""

    cdef readonly object start, xs, ys
    cdef const long long[::1] start_v, xs_v, ys_v
    cdef Py_ssize_t n

    def __init__(self, const int[::1] pi, const int[::1] pj,
                 const long long[:, :, ::1] windows, shortlist):
        cdef const unsigned char[:, ::1] short = np.ascontiguousarray(
            shortlist, dtype=np.bool_).view(np.uint8)
        self.n = short.shape[0]
        self.start = np.zeros(self.n * self.n + 1, np.int64)
        none = np.empty(0, np.int64)
        m = _pair_lists(pi, pj, windows, short, False, none, none, self.start)
        self.xs, self.ys = np.empty(m, np.int64), np.empty(m, np.int64)
        _pair_lists(pi, pj, windows, short, True, self.xs, self.ys, self.start)
        self.start_v, self.xs_v, self.ys_v = self.start, self.xs, self.ys


cdef Py_ssize_t _pair_lists(const int[::1] pi, const int[::1] pj,
                            const long long[:, :, ::1] windows,
                            const unsigned char[:, ::1] short, bint fill, long long[::1] xs,
                            long long[::1] ys, long long[::1] start) noexcept nogil:
    cdef Py_ssize_t m = 0, n = short.shape[0], a, b, e, half
    cdef long long x, y
    for a in range(n):
        for b in range(n):
            start[a * n + b] = m
            if b <= a:
                continue
            for half in range(2):
                for e in range(windows[a, b, 0], windows[a, b, 1]):
                    if half == 0:
                        x, y = pi[e], pj[e]
                    else:
                        x, y = pj[e], pi[e]
                    if short[a, x] and short[b, y]:
                        if fill:
                            xs[m], ys[m] = x, y
                        m += 1
    start[n * n] = m
    return m
