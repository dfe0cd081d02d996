"""Pair tables with their neighbour lists, and the joins on a grouped table window.

A pair table lists catalog pairs (i < j) sorted by angle. Its neighbour lists give, for
each catalog star s, its partners in the pairs where s is the first star (``lo`` run) and
in those where it is the second (``hi`` run), each run in table order, so by angle: the
partners of s within an angle window are two binary searches away. Entry order is kept
throughout, so that the joins give the rows in the order a stable sort would. A
hypothesis table holds rows of catalog stars, one column per observed star: a join grows
it by a grouped pair window that shares a star with it (:func:`join_extend`) or narrows
it by one between two of its stars (:func:`join_close`).
"""

import numpy as np

cimport numpy as cnp

from startrack._core._threads import in_threads

cnp.import_array()


cdef class PairNeighbours:
    """A pair table (``pi`` < ``pj`` by catalog row, ``angle`` ascending) and its
    neighbour lists over ``n_catalog`` stars: the partners of star s as first star of a
    pair are ``nbr_lo[start_lo[s]:start_lo[s + 1]]`` with the pair angles in ``ang_lo``,
    as second star in ``nbr_hi`` and ``ang_hi``. Partners and angles sit side by side per
    star: a window search then reads a few cache lines, not the table. ``lists`` holds
    the six arrays (start_lo, nbr_lo, ang_lo, start_hi, nbr_hi, ang_hi). ``threaded``:
    the two runs built in two threads at once (the same arrays). ``lists``: those six
    arrays as built before for this table (a mapped cache entry), taken as they are."""

    def __init__(self, pi, pj, angle, Py_ssize_t n_catalog, bint threaded=False,
                 lists=None):
        self.pi = np.ascontiguousarray(pi, dtype=np.int32)
        self.pj = np.ascontiguousarray(pj, dtype=np.int32)
        self.angle = np.ascontiguousarray(angle, dtype=np.float64)
        self.n_catalog = n_catalog
        cdef Py_ssize_t m = self.pi.shape[0]
        if lists is not None:  # a process reads them in milliseconds; a build took 0.3 s
            start_lo, nbr_lo, ang_lo, start_hi, nbr_hi, ang_hi = lists
            if len(start_lo) != n_catalog + 1 or len(nbr_lo) != m or len(nbr_hi) != m:
                raise ValueError("neighbour lists of another table")
        else:
            start_lo, start_hi = (np.zeros(n_catalog + 1, np.int64),
                                  np.zeros(n_catalog + 1, np.int64))
            nbr_lo, nbr_hi = np.empty(m, np.int32), np.empty(m, np.int32)
            ang_lo, ang_hi = np.empty(m, np.float64), np.empty(m, np.float64)
            # the two runs read the same table and write apart: a thread each when threaded
            runs = ((self.pi, self.pj, self.angle, start_lo, nbr_lo, ang_lo),
                    (self.pj, self.pi, self.angle, start_hi, nbr_hi, ang_hi))
            if threaded:
                in_threads(lambda t: _lists(*runs[t]), 2)
            else:
                for run in runs:
                    _lists(*run)
        self.start_lo, self.nbr_lo, self.ang_lo = start_lo, nbr_lo, ang_lo
        self.start_hi, self.nbr_hi, self.ang_hi = start_hi, nbr_hi, ang_hi
        self.lists = (start_lo, nbr_lo, ang_lo, start_hi, nbr_hi, ang_hi)


def _lists(const int[::1] own, const int[::1] other, const double[::1] angle,
           long long[::1] start, int[::1] nbr, double[::1] ang):
    """One run of the neighbour lists: the partners ``other[e]`` (and angles) of each
    star as ``own[e]``, grouped by star in table order (a stable counting sort);
    ``start`` holds n_catalog + 1 zeros, ``nbr`` and ``ang`` one entry per pair."""
    cdef Py_ssize_t m = own.shape[0], n = start.shape[0] - 1, e, s
    fill_arr = np.empty(n, np.int64)
    cdef long long[::1] fill = fill_arr
    cdef int a
    with nogil:
        for e in range(m):
            start[own[e] + 1] += 1
        for s in range(n):
            start[s + 1] += start[s]
        for s in range(n):
            fill[s] = start[s]
        for e in range(m):
            a = own[e]
            nbr[fill[a]], ang[fill[a]] = other[e], angle[e]
            fill[a] += 1


cdef Py_ssize_t _join_fill(const long long[:, :] hyps, Py_ssize_t col, const int[::1] head,
                           const int[::1] nxt, const int[::1] val,
                           long long[:, ::1] out) noexcept nogil:
    """:func:`join_extend`'s rows written into ``out`` while it has room; returns how
    many there are in all."""
    cdef Py_ssize_t m = hyps.shape[0], w = hyps.shape[1], cap = out.shape[0]
    cdef Py_ssize_t count = 0, r, c, p
    cdef long long new
    cdef bint clash
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


cdef object join_extend_rows(const long long[:, :] hyps, Py_ssize_t col, const int[::1] head,
                             const int[::1] nxt, const int[::1] val, Py_ssize_t max_rows):
    """Each row of ``hyps`` once per partner of its column ``col`` in the grouped pairs
    (head, nxt, val), the partner appended; partners already in the row are refused.
    Returns (rows, total): total counts every joined row, rows holds at most
    ``max_rows`` of them."""
    cdef Py_ssize_t cap = min(max_rows, 1024), count
    while True:  # a second pass only when the first guess of the row count was short
        out = np.empty((cap, hyps.shape[1] + 1), np.int64)
        count = _join_fill(hyps, col, head, nxt, val, out)
        if count <= cap or cap == max_rows:
            return out[:min(count, cap)], count
        cap = min(count, max_rows)


cdef object join_close_rows(object hyps, Py_ssize_t col_p, Py_ssize_t col_q,
                            const int[::1] head, const int[::1] nxt, const int[::1] val):
    """The rows of ``hyps`` whose catalog stars in columns (col_p, col_q) are one of the
    grouped pairs."""
    cdef const long long[:, :] rows = hyps
    keep = np.zeros(rows.shape[0], np.bool_)
    cdef unsigned char[::1] mark = keep.view(np.uint8)
    cdef Py_ssize_t r
    for r in range(rows.shape[0]):
        mark[r] = linked(head, nxt, val, rows[r, col_p], rows[r, col_q])
    return hyps[keep]


def group_pairs(PairNeighbours tab, Py_ssize_t s0, Py_ssize_t s1, bint hi_first):
    """Table entries [s0, s1) grouped per star (:func:`group_window`) into fresh arrays:
    (head, nxt, val)."""
    head = np.full(tab.n_catalog, -1, np.int32)
    nxt, val = np.empty(2 * (s1 - s0), np.int32), np.empty(2 * (s1 - s0), np.int32)
    group_window(tab.pi, tab.pj, s0, s1, hi_first, head, nxt, val)
    return head, nxt, val


def join_extend(const long long[:, :] hyps, Py_ssize_t col, const int[::1] head,
                const int[::1] nxt, const int[::1] val, Py_ssize_t max_rows):
    """:func:`join_extend_rows` on a grouping of :func:`group_pairs`: (rows, total)."""
    return join_extend_rows(hyps, col, head, nxt, val, max_rows)


def join_close(hyps, Py_ssize_t col_p, Py_ssize_t col_q, const int[::1] head,
               const int[::1] nxt, const int[::1] val):
    """:func:`join_close_rows` on a grouping of :func:`group_pairs`."""
    return join_close_rows(hyps, col_p, col_q, head, nxt, val)
