# Every pair of observed and catalog positions within a radius (included in
# _nearest.pyx, whose catalog grid it scans).


cdef class _PairList:
    """Pairs appended observed star by observed star, each star's kept sorted by catalog
    index (insertion: a star has few pairs); the arrays grow by doubling."""
    cdef long long[::1] obs
    cdef long long[::1] cat
    cdef double[::1] d2
    cdef Py_ssize_t count

    def __cinit__(self, Py_ssize_t cap):
        self.obs = empty_i64(cap)
        self.cat = empty_i64(cap)
        self.d2 = empty_f64(cap)
        self.count = 0

    cdef void add(self, Py_ssize_t first, Py_ssize_t i, Py_ssize_t j, double d2) except *:
        cdef Py_ssize_t k = self.count, cap = self.obs.shape[0]
        if k == cap:
            self.obs = np.concatenate([self.obs.base[:k], empty_i64(cap)])
            self.cat = np.concatenate([self.cat.base[:k], empty_i64(cap)])
            self.d2 = np.concatenate([self.d2.base[:k], empty_f64(cap)])
        while k > first and self.cat[k - 1] > j:
            self.obs[k], self.cat[k], self.d2[k] = self.obs[k - 1], self.cat[k - 1], self.d2[k - 1]
            k -= 1
        self.obs[k], self.cat[k], self.d2[k] = i, j, d2
        self.count += 1

    cdef Pairs done(self, long long[::1] start):
        cdef Pairs out = Pairs.__new__(Pairs)
        cdef Py_ssize_t n = self.count
        out.obs, out.cat, out.d2 = self.obs.base[:n], self.cat.base[:n], self.d2.base[:n]
        out.start = start
        return out


cdef Pairs pairs_within(const double[::1] ox, const double[::1] oy, const double[::1] x,
                        const double[::1] y, double radius2, NearestScratch scratch=None):
    """Every pair of an observed star (ox, oy) and a catalog star (x, y) whose squared
    distance is <= ``radius2``, by observed then catalog index. A NaN position pairs with
    nothing. Each observed star scans the cells its radius, a hair widened so that
    rounding cannot drop a pair the exact test keeps, reaches."""
    cdef Py_ssize_t n = ox.shape[0], m = x.shape[0], i, j, gx, gy, q, c
    cdef Py_ssize_t gx0 = 0, gx1 = -1, gy0 = 0, gy1 = -1
    cdef long long[::1] start = zeros_i64(n + 1)
    cdef _PairList found = _PairList(n + 16)
    cdef double half = sqrt(radius2) * (1.0 + 1e-9) + 1e-9 if radius2 >= 0.0 else -1.0
    cdef double pad, dx, dy, d2
    cdef _Cells cells
    cells.ok = False
    if radius2 < INFINITY and m > 0 and n > 0:
        if scratch is None:
            scratch = NearestScratch.__new__(NearestScratch)
        cells = _catalog_grid(x, y, fmax(half, 0.0), scratch)
    for i in range(n):
        start[i] = found.count
        if half < 0.0 or isnan(ox[i]) or isnan(oy[i]):
            continue
        if not cells.ok:  # every catalog star, in order
            for j in range(m):
                dx, dy = ox[i] - x[j], oy[i] - y[j]
                d2 = dx * dx + dy * dy
                if d2 <= radius2:
                    found.add(start[i], i, j, d2)
            continue
        pad = half + 1e-12 * _greater(fabs(ox[i]), fabs(oy[i]))
        _cell_span(ox[i], pad, cells.grid.x0, cells.grid.size, cells.grid.nx, &gx0, &gx1)
        _cell_span(oy[i], pad, cells.grid.y0, cells.grid.size, cells.grid.ny, &gy0, &gy1)
        for gy in range(gy0, gy1 + 1):
            for gx in range(gx0, gx1 + 1):
                c = gy * cells.grid.nx + gx
                for q in range(cells.start[c], cells.start[c + 1]):
                    j = cells.order[q]
                    dx, dy = ox[i] - x[j], oy[i] - y[j]
                    d2 = dx * dx + dy * dy
                    if d2 <= radius2:
                        found.add(start[i], i, j, d2)
    start[n] = found.count
    return found.done(start)
