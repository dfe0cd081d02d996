# A pair table with its neighbour lists, and the inline walks over them that the Pyramid,
# angle and hybrid searches share: windowed partner search and per-star grouping of a
# table window, with its membership test.

from startrack._core.database.partners cimport run_partners
from startrack._core._sort cimport first_at_least


cdef class PairNeighbours:
    cdef readonly Py_ssize_t n_catalog
    cdef const int[::1] pi
    cdef const int[::1] pj
    cdef const double[::1] angle
    cdef const long long[::1] start_lo
    cdef const int[::1] nbr_lo
    cdef const double[::1] ang_lo
    cdef const long long[::1] start_hi
    cdef const int[::1] nbr_hi
    cdef const double[::1] ang_hi
    cdef readonly tuple lists


cdef object join_extend_rows(const long long[:, :] hyps, Py_ssize_t col, const int[::1] head,
                             const int[::1] nxt, const int[::1] val, Py_ssize_t max_rows)
cdef object join_close_rows(object hyps, Py_ssize_t col_p, Py_ssize_t col_q,
                            const int[::1] head, const int[::1] nxt, const int[::1] val)


cdef inline Py_ssize_t partners(PairNeighbours tab, Py_ssize_t star, double lo, double hi,
                                bint hi_first, long long[::1] out) noexcept nogil:
    """Write the partners of ``star`` whose pair angle lies in [lo, hi] into ``out``;
    return how many (all of them: at most len(out) are written). The ``lo`` run (star
    first in the pair) comes first unless ``hi_first``: the order of a stable sort of the
    pairs seen one way round or the other."""
    if hi_first:
        return run_partners(tab.start_lo, tab.nbr_lo, tab.ang_lo, star, lo, hi, out,
                            run_partners(tab.start_hi, tab.nbr_hi, tab.ang_hi, star, lo, hi,
                                         out, 0))
    return run_partners(tab.start_hi, tab.nbr_hi, tab.ang_hi, star, lo, hi, out,
                        run_partners(tab.start_lo, tab.nbr_lo, tab.ang_lo, star, lo, hi,
                                     out, 0))


cdef inline void group_window(const int[::1] pi, const int[::1] pj, Py_ssize_t s0,
                              Py_ssize_t s1, bint hi_first, int[::1] head, int[::1] nxt,
                              int[::1] val) noexcept nogil:
    """Link the pairs of table entries [s0, s1), both ways round, into per-star lists:
    star x's partners are val[p] for p = head[x], nxt[p], ... until -1, in the order of a
    stable sort of the pairs by x (x as first star first, unless ``hi_first``). ``head``
    must be all -1 (:func:`ungroup_window` resets it). Reads the window in sequence and
    writes only into the small per-frame arrays, which stay in cache."""
    cdef Py_ssize_t w = s1 - s0, e, p
    cdef int step, half, x, y
    for step in range(2):  # insert backwards: lists come out forwards
        half = step if hi_first else 1 - step
        e = s1 - 1
        while e >= s0:
            if half == 0:
                x, y = pi[e], pj[e]
            else:
                x, y = pj[e], pi[e]
            p = (e - s0) + half * w
            nxt[p] = head[x]
            val[p] = y
            head[x] = <int>p
            e -= 1


cdef inline void ungroup_window(const int[::1] pi, const int[::1] pj, Py_ssize_t s0,
                                Py_ssize_t s1, int[::1] head) noexcept nogil:
    cdef Py_ssize_t e
    for e in range(s0, s1):
        head[pi[e]] = -1
        head[pj[e]] = -1


cdef inline bint linked(const int[::1] head, const int[::1] nxt, const int[::1] val,
                        Py_ssize_t x, Py_ssize_t y) noexcept nogil:
    """Whether y is one of x's partners in a grouping (:func:`group_window`)."""
    cdef Py_ssize_t p = head[x]
    while p >= 0:
        if val[p] == y:
            return True
        p = nxt[p]
    return False
