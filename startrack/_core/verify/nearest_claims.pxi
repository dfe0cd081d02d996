# The nearest observed star claimed by each projected catalog star, on a grid of the
# observed stars built once per frame (included in nearest.pyx): nearest_matches with
# the roles turned, so that a frame's many matchings build no grid of their own.


cdef class PointGrid:
    pass


@cython.cdivision(True)  # the size is >= 1e-9
cdef PointGrid point_grid(const double[::1] x, const double[::1] y):
    """The finite positions in a grid of about one per cell (none: one empty cell)."""
    cdef Py_ssize_t m = x.shape[0], j, count = 0
    cdef double x0 = INFINITY, y0 = INFINITY, x1 = -INFINITY, y1 = -INFINITY
    for j in range(m):
        if isfinite(x[j]) and isfinite(y[j]):
            x0, x1 = _lesser(x0, x[j]), _greater(x1, x[j])
            y0, y1 = _lesser(y0, y[j]), _greater(y1, y[j])
            count += 1
    cdef PointGrid out = PointGrid.__new__(PointGrid)
    out.cells = _no_cells()
    if not (x1 - x0 < INFINITY and y1 - y0 < INFINITY):  # none finite, or overflow
        if count:
            return out  # not ok: the callers take their own way
        x0, x1, y0, y1 = 0.0, 0.0, 0.0, 0.0  # one empty cell
    cdef Py_ssize_t cells = max(1, <Py_ssize_t>sqrt(<double>count))
    cdef Grid grid
    grid.size = fmax(fmax((x1 - x0) / cells, (y1 - y0) / cells), 1e-9)
    grid.inv = 1.0 / grid.size
    grid.x0, grid.y0 = x0, y0
    grid.nx = <Py_ssize_t>fmin((x1 - x0) / grid.size, <double>cells) + 1
    grid.ny = <Py_ssize_t>fmin((y1 - y0) / grid.size, <double>cells) + 1
    cdef NearestScratch held = NearestScratch.__new__(NearestScratch)
    out.cells = _bucket(x, y, grid, held)
    out.start, out.order = held.start, held.order
    return out


cdef inline bint _in_window(const Reach* r, double x, double y) noexcept nogil:
    return r.lo_x <= x <= r.hi_x and r.lo_y <= y <= r.hi_y


cdef Py_ssize_t claim_nearest(PointGrid grid, const double[::1] ox, const double[::1] oy,
                              const double[::1] x, const double[::1] y,
                              const unsigned char[::1] valid, Reach reach,
                              long long[::1] nearest, double[::1] dist2, Reach wide,
                              long long[::1] wide_nearest, double[::1] wide_dist2,
                              Py_ssize_t* wide_in) noexcept:
    """Each valid projected star j (x[j], y[j]), in order, in ``reach``'s window claims
    the observed stars (ox, oy) within its radius that have no nearer claim: ``nearest``
    and ``dist2`` (-1 and inf beforehand) end as nearest_matches leaves them for the stars
    in the window, the observed star's nearest within the radius (on a tie the first).
    The same for ``wide`` at once unless its radius is negative (``wide_in``: how many in
    its window). Returns how many lie in ``reach``'s window. The grid must be ok, the
    radii finite."""
    cdef const Cells* cells = &grid.cells
    cdef Py_ssize_t m = x.shape[0], j, i, q, c, gx, gy, n_in = 0
    cdef Py_ssize_t gx0 = 0, gx1 = -1, gy0 = 0, gy1 = -1
    cdef double r2 = reach.radius * reach.radius, w2 = wide.radius * wide.radius
    cdef double half = reach.radius * (1.0 + 1e-9) + 1e-9
    cdef double wide_half = wide.radius * (1.0 + 1e-9) + 1e-9
    cdef double pad, d, dx, dy
    cdef bint near, far
    wide_in[0] = 0
    for j in range(m):
        if not valid[j]:
            continue
        near = _in_window(&reach, x[j], y[j])
        far = wide.radius >= 0.0 and _in_window(&wide, x[j], y[j])
        n_in += near
        wide_in[0] += far
        if not (near or far):
            continue
        pad = _greater(half if near else 0.0, wide_half if far else 0.0)
        pad = pad + 1e-12 * _greater(fabs(x[j]), fabs(y[j]))
        _cell_span(x[j], pad, cells.grid.x0, cells.grid.inv, cells.grid.nx, &gx0, &gx1)
        _cell_span(y[j], pad, cells.grid.y0, cells.grid.inv, cells.grid.ny, &gy0, &gy1)
        for gy in range(gy0, gy1 + 1):
            for gx in range(gx0, gx1 + 1):
                c = gy * cells.grid.nx + gx
                for q in range(cells.start[c], cells.start[c + 1]):
                    i = cells.order[q]
                    dx, dy = ox[i] - x[j], oy[i] - y[j]  # as nearest_matches: the same bits
                    d = dx * dx + dy * dy
                    if near and d <= r2 and (nearest[i] < 0 or d < dist2[i]):
                        nearest[i], dist2[i] = j, d
                    if far and d <= w2 and (wide_nearest[i] < 0 or d < wide_dist2[i]):
                        wide_nearest[i], wide_dist2[i] = j, d
    return n_in
