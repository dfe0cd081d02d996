# Every pair of observed and catalog positions within a radius (included in
# nearest.pyx, whose catalog grid it scans).


cdef struct _PairBuf:
    # The pairs found so far, in a NearestScratch's pair buffers (pointers: refreshed
    # whenever the buffers grow).
    long long* obs
    long long* cat
    double* d2
    Py_ssize_t count
    Py_ssize_t cap


cdef void _pairs_grow(_PairBuf* b, NearestScratch s) except *:
    """Twice the room, the pairs so far kept."""
    cdef Py_ssize_t cap = 2 * b.cap
    cdef long long[::1] obs = empty_i64(cap), cat = empty_i64(cap)
    cdef double[::1] d2 = empty_f64(cap)
    memcpy(&obs[0], b.obs, b.count * sizeof(long long))
    memcpy(&cat[0], b.cat, b.count * sizeof(long long))
    memcpy(&d2[0], b.d2, b.count * sizeof(double))
    s.pair_obs, s.pair_cat, s.pair_d2 = obs, cat, d2
    b.obs, b.cat, b.d2, b.cap = &obs[0], &cat[0], &d2[0], cap


cdef inline void _pairs_add(_PairBuf* b, NearestScratch s, Py_ssize_t first, Py_ssize_t i,
                            Py_ssize_t j, double d2) except *:
    """Append observed star i's pair with catalog star j, kept sorted by catalog index
    among its pairs from ``first`` on (insertion: a star has few pairs)."""
    if b.count == b.cap:
        _pairs_grow(b, s)
    cdef Py_ssize_t k = b.count
    while k > first and b.cat[k - 1] > j:
        b.obs[k], b.cat[k], b.d2[k] = b.obs[k - 1], b.cat[k - 1], b.d2[k - 1]
        k -= 1
    b.obs[k], b.cat[k], b.d2[k] = i, j, d2
    b.count += 1


cdef Pairs pairs_in(const double[::1] ox, const double[::1] oy, const double[::1] x,
                    const double[::1] y, double radius2, NearestScratch scratch):
    """:func:`pairs_within` in ``scratch``'s buffers: valid until its next pairing."""
    cdef Cells cells = _no_cells()
    if radius2 < INFINITY and x.shape[0] > 0 and ox.shape[0] > 0:
        cells = _catalog_grid(x, y, fmax(_pair_half(radius2), 0.0), scratch)
    return _pairs_on(ox, oy, x, y, radius2, &cells, scratch)


cdef Pairs pairs_and_crowded(const double[::1] ox, const double[::1] oy,
                             const double[::1] x, const double[::1] y, double radius2,
                             double resolve2, NearestScratch scratch,
                             unsigned char[::1] crowded):
    """:func:`pairs_in`, and per catalog star whether another lies closer than
    sqrt(``resolve2``) written into ``crowded``, on one grid of the catalog positions."""
    cdef Cells cells = _no_cells(), none = _no_cells()
    cdef bint pair_grid = radius2 < INFINITY and x.shape[0] > 0 and ox.shape[0] > 0
    if pair_grid or resolve2 < INFINITY:
        cells = _catalog_grid(x, y, fmax(_pair_half(radius2), 0.0), scratch)
    _crowded_on(x, y, resolve2, &cells if resolve2 < INFINITY else &none, crowded)
    return _pairs_on(ox, oy, x, y, radius2, &cells if pair_grid else &none, scratch)


cdef inline double _pair_half(double radius2) noexcept nogil:
    """The cells' least size for pairs within sqrt(``radius2``): the radius, a hair
    widened (-1: none is within)."""
    return sqrt(radius2) * (1.0 + 1e-9) + 1e-9 if radius2 >= 0.0 else -1.0


cdef Pairs _pairs_on(const double[::1] ox, const double[::1] oy, const double[::1] x,
                     const double[::1] y, double radius2, const Cells* cells,
                     NearestScratch scratch):
    """The pairs within sqrt(``radius2``), on the catalog grid ``cells`` (not ok: every
    pair), in ``scratch``'s buffers."""
    cdef Py_ssize_t n = ox.shape[0], m = x.shape[0], i, j, gx, gy, q, c
    cdef Py_ssize_t gx0 = 0, gx1 = -1, gy0 = 0, gy1 = -1
    scratch.pair_start = _room_i64(scratch.pair_start, n + 1)
    cdef long long* start = &scratch.pair_start[0]
    cdef _PairBuf found
    scratch.pair_obs = _room_i64(scratch.pair_obs, n + 16)
    scratch.pair_cat = _room_i64(scratch.pair_cat, n + 16)
    scratch.pair_d2 = _room_f64(scratch.pair_d2, n + 16)
    found.obs, found.cat, found.d2 = (&scratch.pair_obs[0], &scratch.pair_cat[0],
                                      &scratch.pair_d2[0])
    found.count = 0
    found.cap = min(scratch.pair_obs.shape[0], scratch.pair_cat.shape[0],
                    scratch.pair_d2.shape[0])
    cdef double half = _pair_half(radius2)
    cdef double pad, dx, dy, d2
    for i in range(n):
        start[i] = found.count
        if half < 0.0 or isnan(ox[i]) or isnan(oy[i]):
            continue
        if not cells.ok:  # every catalog star, in order
            for j in range(m):
                dx, dy = ox[i] - x[j], oy[i] - y[j]
                d2 = dx * dx + dy * dy
                if d2 <= radius2:
                    _pairs_add(&found, scratch, start[i], i, j, d2)
            continue
        pad = half + 1e-12 * _greater(fabs(ox[i]), fabs(oy[i]))
        _cell_span(ox[i], pad, cells.grid.x0, cells.grid.inv, cells.grid.nx, &gx0, &gx1)
        _cell_span(oy[i], pad, cells.grid.y0, cells.grid.inv, cells.grid.ny, &gy0, &gy1)
        for gy in range(gy0, gy1 + 1):
            for gx in range(gx0, gx1 + 1):
                c = gy * cells.grid.nx + gx
                for q in range(cells.start[c], cells.start[c + 1]):
                    j = cells.order[q]
                    dx, dy = ox[i] - x[j], oy[i] - y[j]
                    d2 = dx * dx + dy * dy
                    if d2 <= radius2:
                        _pairs_add(&found, scratch, start[i], i, j, d2)
    start[n] = found.count
    cdef Pairs out = Pairs.__new__(Pairs)
    out.obs, out.cat = scratch.pair_obs[:found.count], scratch.pair_cat[:found.count]
    out.d2, out.start = scratch.pair_d2[:found.count], scratch.pair_start[:n + 1]
    return out


cdef Pairs pairs_within(const double[::1] ox, const double[::1] oy, const double[::1] x,
                        const double[::1] y, double radius2, NearestScratch scratch=None):
    """Every pair of an observed star (ox, oy) and a catalog star (x, y) whose squared
    distance is <= ``radius2``, by observed then catalog index, in new arrays. A NaN
    position pairs with nothing. Each observed star scans the cells its radius, a hair
    widened so that rounding cannot drop a pair the exact test keeps, reaches."""
    if scratch is None:
        scratch = NearestScratch.__new__(NearestScratch)
    cdef Pairs held = pairs_in(ox, oy, x, y, radius2, scratch)
    cdef Pairs out = Pairs.__new__(Pairs)
    out.obs, out.cat = _copy_i64(held.obs), _copy_i64(held.cat)
    out.d2, out.start = _copy_f64(held.d2), _copy_i64(held.start)
    return out


cdef long long[::1] _copy_i64(const long long[::1] values):
    cdef long long[::1] out = empty_i64(values.shape[0])
    if values.shape[0]:
        memcpy(&out[0], &values[0], values.shape[0] * sizeof(long long))
    return out


cdef double[::1] _copy_f64(const double[::1] values):
    cdef double[::1] out = empty_f64(values.shape[0])
    if values.shape[0]:
        memcpy(&out[0], &values[0], values.shape[0] * sizeof(double))
    return out


cdef void _crowded_on(const double[::1] x, const double[::1] y, double radius2,
                      const Cells* cells, unsigned char[::1] out) noexcept:
    """Whether each position has another at a squared distance below ``radius2`` (NaN is
    no neighbour), written into ``out``: on the grid ``cells`` of the positions, the cells
    each star's radius reaches (as the pairs scan them), or every pair when not ok."""
    cdef Py_ssize_t m = x.shape[0], i, j, gx, gy, q, c
    cdef Py_ssize_t gx0 = 0, gx1 = -1, gy0 = 0, gy1 = -1
    cdef double half = _pair_half(radius2), pad, dx, dy
    for i in range(m):
        out[i] = False
    if not radius2 > 0.0:
        return  # no squared distance is below it
    for i in range(m):
        if not cells.ok:
            for j in range(m):
                dx, dy = x[i] - x[j], y[i] - y[j]
                if j != i and dx * dx + dy * dy < radius2:
                    out[i] = True
            continue
        if isnan(x[i]) or isnan(y[i]):
            continue
        pad = half + 1e-12 * _greater(fabs(x[i]), fabs(y[i]))
        _cell_span(x[i], pad, cells.grid.x0, cells.grid.inv, cells.grid.nx, &gx0, &gx1)
        _cell_span(y[i], pad, cells.grid.y0, cells.grid.inv, cells.grid.ny, &gy0, &gy1)
        for gy in range(gy0, gy1 + 1):
            for gx in range(gx0, gx1 + 1):
                c = gy * cells.grid.nx + gx
                for q in range(cells.start[c], cells.start[c + 1]):
                    j = cells.order[q]
                    dx, dy = x[i] - x[j], y[i] - y[j]
                    if j != i and dx * dx + dy * dy < radius2:
                        out[i] = True
