"""Pairing of observed and projected catalog positions: the nearest catalog star of each
observed star, and every pair within a radius, on a grid of about one catalog star per
cell, cells no smaller than the radius, so that a frame costs O(n + m) and not O(n m).

Inputs the grid cannot take (an infinite radius, infinite catalog positions) take the
brute-force scan of every pair, which the tests hold the grid to. A frame matched at many
attitudes buckets its observed stars once instead (:class:`PointGrid`,
``nearest_claims.pxi``): each projected star claims the observed stars near it, which
gives the same pairs.
"""

cimport cython
import numpy as np

from libc.math cimport INFINITY, fabs, fmax, fmin, isfinite, isnan, sqrt
from libc.string cimport memcpy, memset

cimport numpy as cnp
from startrack._core._arrays cimport (empty_f64, empty_i64, full_f64, full_i64,
                                      zeros_i64)
from startrack._core._arrays cimport room_f64 as _room_f64, room_i64 as _room_i64

cnp.import_array()  # the C API the _arrays helpers call


cdef class Pairs:
    def __iter__(self):
        """(observed, catalog, squared distance, start offsets), as arrays."""
        return iter((self.obs.base, self.cat.base, self.d2.base, self.start.base))


cdef class Nearest:
    def __iter__(self):
        """(observed, catalog), as arrays."""
        return iter((np.asarray(self.obs), np.asarray(self.cat)))


cdef inline double _lesser(double a, double b) noexcept nogil:
    """fmin of two numbers that are not NaN, inline where libm's is a call (the per-star
    loops below make several)."""
    return b if b < a else a


cdef inline double _greater(double a, double b) noexcept nogil:
    """fmax of two numbers that are not NaN, inline."""
    return b if b > a else a


cdef inline Py_ssize_t _cell_of(double x, double y, Grid grid) noexcept:
    """The cell of a finite position (scaled by ``inv`` as _cell_span scales: the same
    operations, so a position inside a span's reach is in its cells)."""
    cdef Py_ssize_t gx = min(<Py_ssize_t>((x - grid.x0) * grid.inv), grid.nx - 1)
    cdef Py_ssize_t gy = min(<Py_ssize_t>((y - grid.y0) * grid.inv), grid.ny - 1)
    return gy * grid.nx + gx


cdef inline Cells _no_cells() noexcept nogil:
    """No grid (every field set: ``ok`` False)."""
    cdef Cells cells
    memset(&cells, 0, sizeof(Cells))
    return cells


cdef Cells _bucket(const double[::1] x, const double[::1] y, Grid grid,
                   NearestScratch scratch) except *:
    """A stable counting sort of the finite positions into ``grid``'s cells, in the
    scratch's buffers: each cell's end counted, then the positions placed from the last
    down (each cell's end moves to its start)."""
    cdef Py_ssize_t m = x.shape[0], j, c, n_cells = grid.nx * grid.ny
    cdef Cells cells
    cells.grid, cells.ok = grid, True
    scratch.start, scratch.cell = _room_i64(scratch.start, n_cells + 1), _room_i64(scratch.cell, m)
    cdef long long* start = &scratch.start[0]
    cdef long long* cell = &scratch.cell[0]
    memset(start, 0, (n_cells + 1) * sizeof(long long))
    for j in range(m):
        cell[j] = -1
        if isfinite(x[j]) and isfinite(y[j]):
            cell[j] = _cell_of(x[j], y[j], grid)
            start[cell[j]] += 1
    for c in range(n_cells):
        start[c + 1] += start[c]
    scratch.order = _room_i64(scratch.order, start[n_cells])
    cdef long long* order = &scratch.order[0]
    for j in range(m - 1, -1, -1):
        if cell[j] >= 0:
            start[cell[j]] -= 1
            order[start[cell[j]]] = j
    cells.start, cells.order = start, order
    return cells


cdef Cells _catalog_grid(const double[::1] x, const double[::1] y, double half,
                         NearestScratch scratch) except *:
    """The finite catalog positions in a grid of about one per cell, cells no smaller
    than ``half`` (in ``scratch``'s buffers); not ``ok`` with an infinite position, or
    extents that overflow or hold no position."""
    cdef Py_ssize_t m = x.shape[0], j
    cdef double x0 = INFINITY, y0 = INFINITY, x1 = -INFINITY, y1 = -INFINITY
    for j in range(m):
        if isfinite(x[j]) and isfinite(y[j]):
            x0, x1 = _lesser(x0, x[j]), _greater(x1, x[j])
            y0, y1 = _lesser(y0, y[j]), _greater(y1, y[j])
        elif not (isnan(x[j]) or isnan(y[j])):
            return _no_cells()  # inf - inf would be NaN in the extents
    if not (0.0 <= x1 - x0 < INFINITY and 0.0 <= y1 - y0 < INFINITY):
        return _no_cells()
    cdef Py_ssize_t cells = max(1, <Py_ssize_t>sqrt(<double>m))
    cdef Grid grid
    grid.size = fmax(fmax(half, (x1 - x0) / cells), fmax((y1 - y0) / cells, 1e-9))
    grid.inv = 1.0 / grid.size
    grid.x0, grid.y0 = x0, y0
    grid.nx = <Py_ssize_t>fmin((x1 - x0) / grid.size, <double>cells) + 1
    grid.ny = <Py_ssize_t>fmin((y1 - y0) / grid.size, <double>cells) + 1
    return _bucket(x, y, grid, scratch)


cdef inline void _cell_span(double v, double pad, double v0, double inv, Py_ssize_t cells,
                            Py_ssize_t* first, Py_ssize_t* last) noexcept nogil:
    """The first and last cell along one axis that [v - pad, v + pad] reaches (clipped to
    the grid; last < first when it misses it); ``inv``: 1 / the cells' size (a product,
    where a quotient per star costs more)."""
    cdef double lo = (v - pad - v0) * inv, hi = (v + pad - v0) * inv
    if not hi >= 0.0 or not lo < cells:
        first[0], last[0] = 0, -1
        return
    first[0] = <Py_ssize_t>_greater(lo, 0.0)  # neither is NaN past the test above
    last[0] = <Py_ssize_t>_lesser(hi, cells - 1.0)


cdef inline Py_ssize_t _best_in_cells(double x, double y, const double* cx,
                                      const double* cy, const Cells* cells, Py_ssize_t gx0,
                                      Py_ssize_t gx1, Py_ssize_t gy0, Py_ssize_t gy1,
                                      double* best_d) noexcept nogil:
    """The catalog star nearest (x, y) among cells gx0..gx1 x gy0..gy1 (on a tie the lower
    index; -1 if none), its squared distance in ``best_d``."""
    cdef Py_ssize_t best = -1, xx, yy, c, q, j
    cdef double d, dx, dy, top = INFINITY
    for yy in range(gy0, gy1 + 1):
        for xx in range(gx0, gx1 + 1):
            c = yy * cells.grid.nx + xx
            for q in range(cells.start[c], cells.start[c + 1]):
                j = cells.order[q]
                dx, dy = x - cx[j], y - cy[j]
                d = dx * dx + dy * dy
                if d < top or (d == top and j < best):
                    best, top = j, d
    best_d[0] = top
    return best


cdef void _nearest(const double[::1] ox, const double[::1] oy, const double[::1] cx,
                   const double[::1] cy, double radius_px, long long[::1] nearest,
                   double[::1] dist2, NearestScratch scratch) except *:
    """Per observed star, its nearest catalog star if within ``radius_px`` (else -1; on a
    tie the lower index) and the squared distance, written into the two arrays. A
    negative or NaN radius reaches nothing; an infinite one, or infinite catalog
    positions, take a scan of every catalog star."""
    cdef Py_ssize_t n = ox.shape[0], m = cx.shape[0], i, j
    cdef Py_ssize_t gx0 = 0, gx1 = -1, gy0 = 0, gy1 = -1
    cdef double r2 = radius_px * radius_px, half = radius_px * (1.0 + 1e-9) + 1e-9
    cdef double pad, best_d, d, dx, dy
    cdef Py_ssize_t best
    cdef Cells cells = _no_cells()
    if not radius_px >= 0.0 or n == 0:
        return
    if radius_px < INFINITY:
        cells = _catalog_grid(cx, cy, half, scratch)
    for i in range(n):
        if isnan(ox[i]) or isnan(oy[i]):
            continue
        if not cells.ok:
            best, best_d = -1, INFINITY
            for j in range(m):
                dx, dy = ox[i] - cx[j], oy[i] - cy[j]
                d = dx * dx + dy * dy
                if d < best_d:
                    best, best_d = j, d
        else:
            pad = half + 1e-12 * _greater(fabs(ox[i]), fabs(oy[i]))
            _cell_span(ox[i], pad, cells.grid.x0, cells.grid.inv, cells.grid.nx, &gx0, &gx1)
            _cell_span(oy[i], pad, cells.grid.y0, cells.grid.inv, cells.grid.ny, &gy0, &gy1)
            best = _best_in_cells(ox[i], oy[i], &cx[0], &cy[0], &cells, gx0, gx1, gy0, gy1,
                                  &best_d)
        if best >= 0 and best_d <= r2:
            nearest[i], dist2[i] = best, best_d


cdef Nearest nearest_matches(const double[::1] ox, const double[::1] oy,
                             const double[::1] cx, const double[::1] cy, double radius_px,
                             NearestScratch scratch=None):
    """Pair each observed star with its nearest catalog star within ``radius_px``; a
    catalog star claimed by several keeps the nearest (on a tie, the first). ``scratch``:
    the working buffers of the frame's earlier calls to reuse (None: new ones)."""
    if scratch is None:
        scratch = NearestScratch.__new__(NearestScratch)
    cdef Py_ssize_t n = ox.shape[0], m = cx.shape[0]
    scratch.nearest, scratch.dist2 = _room_i64(scratch.nearest, n), _room_f64(scratch.dist2, n)
    scratch.owner = _room_i64(scratch.owner, m)
    cdef long long[::1] nearest = scratch.nearest[:n], owner = scratch.owner[:m]
    cdef double[::1] dist2 = scratch.dist2[:n]
    nearest[:] = -1
    dist2[:] = INFINITY
    owner[:] = -1
    _nearest(ox, oy, cx, cy, radius_px, nearest, dist2, scratch)
    return one_to_one(nearest, dist2, owner)


cdef Nearest one_to_one(const long long[::1] nearest, const double[::1] dist2,
                        long long[::1] owner):
    """The pairs of each observed star i with its nearest catalog star ``nearest[i]``
    (-1: none) at squared distance ``dist2[i]``, a catalog star claimed by several kept by
    the nearest (on a tie, the first); ``owner``: a buffer per catalog star, -1 each."""
    cdef Py_ssize_t n = nearest.shape[0], i, j, k = 0, kept = 0
    for i in range(n):
        j = nearest[i]
        if j >= 0 and (owner[j] < 0 or dist2[i] < dist2[owner[j]]):
            owner[j] = i
    for i in range(n):
        kept += nearest[i] >= 0 and owner[nearest[i]] == i
    cdef Nearest out = Nearest.__new__(Nearest)
    cdef long long[::1] both = empty_i64(2 * kept)  # one array (and typed view) for both
    out.obs, out.cat = both[:kept], both[kept:]
    for i in range(n):
        if nearest[i] >= 0 and owner[nearest[i]] == i:
            out.obs[k], out.cat[k] = i, nearest[i]
            k += 1
    return out


include "nearest_pairs.pxi"
include "nearest_claims.pxi"


def pairs(ox, oy, x, y, double radius2):
    """:func:`pairs_within` from Python: (observed, catalog, squared distance, start)."""
    return tuple(pairs_within(ox, oy, x, y, radius2))


def nearest(ox, oy, cx, cy, double radius_px):
    """The nearest catalog star of each observed star within ``radius_px`` (-1: none) and
    its squared distance (inf: none), before the one-to-one rule."""
    n = len(ox)
    found, dist2 = full_i64(n, -1), full_f64(n, np.inf)
    _nearest(ox, oy, cx, cy, radius_px, found, dist2, NearestScratch.__new__(NearestScratch))
    return found, dist2


def matches(ox, oy, cx, cy, double radius_px):
    """:func:`nearest_matches` from Python: (observed rows ascending, catalog positions)."""
    return tuple(nearest_matches(ox, oy, cx, cy, radius_px))
