"""Pyramid's lost-in-space search (Mortari et al. 2004): catalog triangles of an observed
triple from three pair windows, confirmed by a fourth star, one triple after another
until one gives hypotheses, in one call.

The triangles come from the pattern-star table, the fourth star from the full one
(:class:`~startrack._core.database.pair_tables.PairNeighbours` both). :class:`PyramidSearch` holds what
a matcher keeps for every frame, :class:`PyramidFrame` one frame's stars and counters.
"""

import numpy as np

from libc.math cimport NAN, acos, cos, fabs, isnan, sin, sqrt

from startrack._core._sort cimport first_above, first_at_least
from startrack._core.database.pair_tables cimport (
    PairNeighbours, group_window, linked, partners, ungroup_window,
)


cdef class PyramidSearch:
    """A matcher's constants: the catalog's unit vectors, the full table's neighbour lists
    (the fourth star's), the triangle and pyramid limits, and the grouping heads (all -1
    between calls: scratch that one matcher reuses for every frame)."""

    cdef const double[:, ::1] cat
    cdef PairNeighbours full
    cdef Py_ssize_t max_triangles, max_pyramids
    cdef int[:, ::1] heads
    cdef int[:, ::1] links
    cdef long long[:, ::1] tri
    cdef object buf
    # the confirmation's scratch: each triangle's attitude, whether it is made yet, and
    # the pyramids found (a triple at a wrong scale or a junk frame reaches the
    # confirmation again and again: allocating these on each call cost more than it)
    cdef double[:, :, ::1] rots
    cdef unsigned char[::1] have
    cdef long long[:, ::1] pyramids

    def __init__(self, cat, PairNeighbours full, Py_ssize_t max_triangles,
                 Py_ssize_t max_pyramids):
        self.cat = np.ascontiguousarray(cat, dtype=np.float64)
        self.full = full
        self.max_triangles = max_triangles
        self.max_pyramids = max_pyramids
        self.heads = np.full((2, self.cat.shape[0]), -1, np.int32)
        self.links = np.empty((4, 4096), np.int32)  # next and partner, two groupings
        self.tri = np.empty((max_triangles + 1, 3), np.int64)
        self.buf = np.empty(4096, np.int64)
        self.rots = np.empty((max_triangles + 1, 3, 3))
        self.have = np.zeros(max_triangles + 1, np.uint8)
        self.pyramids = np.empty((max_pyramids, 4), np.int64)

    cdef void room(self, Py_ssize_t size):
        """``links`` rows of at least ``size``."""
        if size > self.links.shape[1]:
            self.links = np.empty((4, 2 * size), np.int32)


cdef class PyramidFrame:
    """One frame's observed unit vectors (brightest first), the angle tolerance and the
    fourth star's radius (radians), its angle table (filled on first use) and the
    counters of the triples tried, triangles found, candidate pairs and pivots."""

    cdef const double[:, ::1] vec
    cdef double[:, ::1] ang
    cdef double tol, radius
    cdef readonly long long triples, triangles, candidates, pivots

    def __init__(self, vec, double tol, double radius):
        self.vec = np.ascontiguousarray(vec, dtype=np.float64)
        ang = np.empty((self.vec.shape[0], self.vec.shape[0]))
        ang.fill(NAN)  # what np.full makes, without its Python layer
        self.ang = ang
        self.tol = tol
        self.radius = radius


cdef inline double _triple(const double[:, ::1] u, Py_ssize_t a, const double[:, ::1] v,
                           Py_ssize_t b, const double[:, ::1] w, Py_ssize_t c) noexcept nogil:
    return (u[a, 0] * (v[b, 1] * w[c, 2] - v[b, 2] * w[c, 1])
            + u[a, 1] * (v[b, 2] * w[c, 0] - v[b, 0] * w[c, 2])
            + u[a, 2] * (v[b, 0] * w[c, 1] - v[b, 1] * w[c, 0]))


cdef inline double _angle(const double[:, ::1] cat, Py_ssize_t a, Py_ssize_t b) noexcept nogil:
    cdef double d = cat[a, 0] * cat[b, 0] + cat[a, 1] * cat[b, 1] + cat[a, 2] * cat[b, 2]
    return acos(min(max(d, -1.0), 1.0))


cdef inline double pair_angle(PyramidFrame f, Py_ssize_t a, Py_ssize_t b) noexcept:
    """The angle between observed stars a and b, computed on first use: a frame solved on
    its first triple needs a few entries of the table."""
    cdef double value = f.ang[a, b], dot
    if isnan(value):
        dot = f.vec[a, 0] * f.vec[b, 0] + f.vec[a, 1] * f.vec[b, 1] + f.vec[a, 2] * f.vec[b, 2]
        value = acos(max(-1.0, min(1.0, dot)))
        f.ang[a, b] = value
        f.ang[b, a] = value
    return value


cdef void _frame(const double[:, ::1] u, Py_ssize_t a, const double[:, ::1] v,
                 Py_ssize_t b, double[3][3] out) noexcept nogil:
    """An orthonormal frame (columns) from two directions: a, a x b, a x (a x b)."""
    cdef double c0 = u[a, 1] * v[b, 2] - u[a, 2] * v[b, 1]
    cdef double c1 = u[a, 2] * v[b, 0] - u[a, 0] * v[b, 2]
    cdef double c2 = u[a, 0] * v[b, 1] - u[a, 1] * v[b, 0]
    cdef double norm = sqrt(c0 * c0 + c1 * c1 + c2 * c2)
    c0, c1, c2 = c0 / norm, c1 / norm, c2 / norm
    out[0][0], out[1][0], out[2][0] = u[a, 0], u[a, 1], u[a, 2]
    out[0][1], out[1][1], out[2][1] = c0, c1, c2
    out[0][2] = u[a, 1] * c2 - u[a, 2] * c1
    out[1][2] = u[a, 2] * c0 - u[a, 0] * c2
    out[2][2] = u[a, 0] * c1 - u[a, 1] * c0


cdef void _triad(const double[:, ::1] vec, Py_ssize_t i, Py_ssize_t j,
                 const double[:, ::1] cat, Py_ssize_t big, Py_ssize_t mid,
                 double[:, ::1] rot) noexcept nogil:
    """The rotation (camera to sky) taking vec[i] to cat[big] exactly and vec[j]'s
    direction about it onto cat[mid]'s (TRIAD): good to the noise, enough to say where a
    star falls."""
    cdef double[3][3] s, c
    cdef int r, k
    _frame(cat, big, cat, mid, s)
    _frame(vec, i, vec, j, c)
    for r in range(3):
        for k in range(3):
            rot[r, k] = s[r][0] * c[k][0] + s[r][1] * c[k][1] + s[r][2] * c[k][2]


cdef struct Windows:
    # The table entries [start, stop) of an observed triple's three sides (i, j), (j, k),
    # (i, k).
    Py_ssize_t start[3]
    Py_ssize_t stop[3]


cdef Windows _windows(PyramidFrame f, PairNeighbours tab, Py_ssize_t i, Py_ssize_t j,
                      Py_ssize_t k) noexcept:
    cdef Windows w
    cdef Py_ssize_t m, n = tab.angle.shape[0]
    cdef Py_ssize_t[3] a = [i, j, i]
    cdef Py_ssize_t[3] b = [j, k, k]
    cdef double side
    for m in range(3):
        side = pair_angle(f, a[m], b[m])
        w.start[m] = first_at_least(tab.angle, 0, n, side - f.tol)
        w.stop[m] = first_above(tab.angle, 0, n, side + f.tol)
    return w


cdef Py_ssize_t _triangles(PyramidSearch s, PyramidFrame f, PairNeighbours tab, Windows w,
                           Py_ssize_t i, Py_ssize_t j, Py_ssize_t k):
    """Catalog triangles (I, J, K) whose three sides match the observed triple i < j < k,
    mirror images removed, in the order of the joins (I, J) by table entry, then K.
    Returns how many, written into ``s.tri``; more than max_triangles means "too many"
    (the search stopped there)."""
    cdef long long[:, ::1] rows = s.tri
    cdef Py_ssize_t s0 = w.start[0], s1 = w.stop[0], t0 = w.start[1], t1 = w.stop[1]
    cdef Py_ssize_t u0 = w.start[2], u1 = w.stop[2]
    if s1 <= s0 or t1 <= t0 or u1 <= u0:
        return 0
    cdef double observed = _triple(f.vec, i, f.vec, j, f.vec, k)
    cdef double sides = sin(f.ang[j, k]) + sin(f.ang[i, k]) + sin(f.ang[i, j])
    cdef bint check = fabs(observed) > f.tol * sides  # a flat triangle keeps both hands
    s.room(2 * max(t1 - t0, u1 - u0))
    cdef int[::1] nxt_jk = s.links[0], val_jk = s.links[1]
    cdef int[::1] nxt_ik = s.links[2], val_ik = s.links[3]
    cdef int[::1] head_jk = s.heads[0], head_ik = s.heads[1]
    group_window(tab.pi, tab.pj, t0, t1, False, head_jk, nxt_jk, val_jk)
    group_window(tab.pi, tab.pj, u0, u1, False, head_ik, nxt_ik, val_ik)
    cdef Py_ssize_t count = 0, e, p
    cdef int half, big, small, kk
    for half in range(2):
        for e in range(s0, s1):
            if half == 0:
                big, small = tab.pi[e], tab.pj[e]
            else:
                big, small = tab.pj[e], tab.pi[e]
            p = head_jk[small]
            while p >= 0 and count <= s.max_triangles:
                kk = val_jk[p]
                p = nxt_jk[p]
                if kk == big or not linked(head_ik, nxt_ik, val_ik, big, kk):
                    continue
                if check and (_triple(s.cat, big, s.cat, small, s.cat, kk) > 0) != (
                        observed > 0):
                    continue
                rows[count, 0], rows[count, 1], rows[count, 2] = big, small, kk
                count += 1
    ungroup_window(tab.pi, tab.pj, t0, t1, head_jk)
    ungroup_window(tab.pi, tab.pj, u0, u1, head_ik)
    return count


cdef inline double _cosine(const double[:, ::1] rot, const double[:, ::1] vec, Py_ssize_t r,
                           const double[:, ::1] cat, Py_ssize_t star) noexcept nogil:
    """The cosine between catalog star ``star`` and where ``rot`` puts observed r."""
    cdef double p[3]
    cdef int m
    for m in range(3):
        p[m] = rot[m, 0] * vec[r, 0] + rot[m, 1] * vec[r, 1] + rot[m, 2] * vec[r, 2]
    return p[0] * cat[star, 0] + p[1] * cat[star, 1] + p[2] * cat[star, 2]


cdef bint _pins(PyramidSearch s, PyramidFrame f, const long long[:, ::1] tri, Py_ssize_t t,
                Py_ssize_t star, Py_ssize_t r, const long long[::1] ijk) noexcept:
    """Whether catalog star ``star`` stands for observed r beside triangle t: its angles
    to the triangle's second and third stars match r's to j and k."""
    if star == tri[t, 1] or star == tri[t, 2]:
        return False
    if fabs(_angle(s.cat, tri[t, 1], star) - pair_angle(f, ijk[1], r)) > f.tol:
        return False
    return fabs(_angle(s.cat, tri[t, 2], star) - pair_angle(f, ijk[2], r)) <= f.tol


cdef tuple _confirm(PyramidSearch s, PyramidFrame f, const long long[:, ::1] tri,
                    const long long[::1] ijk):
    """The brightest fourth star r confirming 1 to ``max_pyramids`` pyramids (I, J, K, R):
    catalog stars R whose angles to I, J, K all lie within the tolerance of the observed
    angles from r to i, j, k, and which lie within the radius of where the triangle's
    attitude puts r (so that a flat triangle's mirror point does not count). Returns
    (r, rows: a new array) or (-1, no rows)."""
    cdef Py_ssize_t i = ijk[0], j = ijk[1], k = ijk[2], r, t, q, n_r, count, star
    cdef long long[:, ::1] rows = s.pyramids
    cdef double[:, :, ::1] rots = s.rots
    cdef unsigned char[::1] have = s.have
    cdef long long[::1] buf = s.buf
    for t in range(tri.shape[0]):
        have[t] = False
    cdef double cos_radius = cos(f.radius), side
    for r in range(f.vec.shape[0]):
        if r == i or r == j or r == k:
            continue
        count = 0
        for t in range(tri.shape[0]):
            side = pair_angle(f, i, r)
            n_r = partners(s.full, tri[t, 0], side - f.tol, side + f.tol, i > r, buf)
            if n_r > buf.shape[0]:
                s.buf = np.empty(2 * n_r, np.int64)
                buf = s.buf
                n_r = partners(s.full, tri[t, 0], side - f.tol, side + f.tol, i > r, buf)
            for q in range(n_r):
                star = buf[q]
                if not _pins(s, f, tri, t, star, r, ijk):
                    continue
                if not have[t]:
                    _triad(f.vec, i, j, s.cat, tri[t, 0], tri[t, 1], rots[t])
                    have[t] = True
                if _cosine(rots[t], f.vec, r, s.cat, star) < cos_radius:
                    continue
                if count < s.max_pyramids:
                    rows[count, 0], rows[count, 1] = tri[t, 0], tri[t, 1]
                    rows[count, 2], rows[count, 3] = tri[t, 2], star
                count += 1
        if 1 <= count <= s.max_pyramids:
            return r, np.array(s.pyramids[:count])
    return -1, None


def search(PyramidSearch matcher, PyramidFrame frame, PairNeighbours tab,
           const long long[:, ::1] triples, Py_ssize_t start):
    """Try ``triples`` (T x 3, i < j < k) from ``start`` on until one gives hypotheses,
    its triangles looked up in ``tab``. Returns (next triple, observed stars (3 or 4),
    hypothesis rows of catalog stars); next = T when none did. The frame's counters
    accumulate."""
    cdef Py_ssize_t n = frame.vec.shape[0], t, count, r, i, j, k
    cdef Windows w
    for t in range(start, triples.shape[0]):
        i, j, k = triples[t, 0], triples[t, 1], triples[t, 2]
        frame.triples += 1
        w = _windows(frame, tab, i, j, k)
        frame.candidates += (w.stop[0] - w.start[0] + w.stop[1] - w.start[1]
                             + w.stop[2] - w.start[2])
        count = _triangles(matcher, frame, tab, w, i, j, k)
        frame.triangles += min(count, matcher.max_triangles)
        if count == 0 or count > matcher.max_triangles:
            continue
        if n == 3:
            if count <= matcher.max_pyramids:
                return t + 1, np.array([i, j, k], np.int64), np.array(matcher.tri[:count])
            continue
        frame.pivots += 3 * (n - 3)
        r, rows = _confirm(matcher, frame, matcher.tri[:count], triples[t])
        if r >= 0:
            return t + 1, np.array([i, j, k, r], np.int64), rows
    return triples.shape[0], np.zeros(0, np.int64), np.zeros((0, 4), np.int64)
