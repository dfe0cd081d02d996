# The pairing of a frame's observed stars with projected catalog stars (included in
# verification.pyx): the widened image a match takes its stars from, the selection, the
# matching on the frame's grid of observed stars, and the count of confirmed stars.


cdef struct _Bounds:
    # The image widened by a margin (px), as within() tests a projected star.
    double lo_x, hi_x, lo_y, hi_y


cdef inline _Bounds _widened(Geometry g, double margin) noexcept:
    cdef _Bounds b
    b.lo_x, b.hi_x = -0.5 - margin, g.width - 0.5 + margin
    b.lo_y, b.hi_y = -0.5 - margin, g.height - 0.5 + margin
    return b


cdef inline bint _inside(const double* x, const double* y, const unsigned char* valid,
                         Py_ssize_t i, _Bounds b) noexcept:
    # pointers: a memoryview argument costs a reference count per call
    return valid[i] and b.lo_x <= x[i] <= b.hi_x and b.lo_y <= y[i] <= b.hi_y


cdef unsigned char[::1] within(Projection p, Geometry g, double margin):
    """Which projected stars fall in the image widened by ``margin`` pixels."""
    cdef _Bounds b = _widened(g, margin)
    cdef Py_ssize_t i
    cdef unsigned char[::1] inside = zeros_u8(p.x.shape[0])
    for i in range(p.x.shape[0]):
        inside[i] = _inside(&p.x[0], &p.y[0], &p.valid[0], i, b)
    return inside


cdef class _Selection:
    """The projected stars inside a margin: their positions and pixel positions."""
    cdef long long[::1] where
    cdef double[::1] x
    cdef double[::1] y


cdef _Selection _select(Projection p, Geometry g, double margin, VerifyScratch work):
    # within()'s test, twice (count, then fill): cheaper than allocating its flags; the
    # selection lives in ``work`` (its reader copies what it keeps)
    cdef _Bounds b = _widened(g, margin)
    cdef const double* x = &p.x[0]
    cdef const double* y = &p.y[0]
    cdef const unsigned char* valid = &p.valid[0]
    cdef Py_ssize_t n = p.x.shape[0], i, k = 0, m = 0
    for i in range(n):
        m += _inside(x, y, valid, i, b)
    cdef _Selection s = _Selection.__new__(_Selection)
    work.where, work.x, work.y = (room_i64(work.where, m), room_f64(work.x, m),
                                  room_f64(work.y, m))
    s.where, s.x, s.y = work.where[:m], work.x[:m], work.y[:m]
    for i in range(n):
        if _inside(x, y, valid, i, b):
            s.where[k], s.x[k], s.y[k] = i, x[i], y[i]
            k += 1
    return s


cdef Matches match_projected(Frame frame, Projection projection, double radius):
    """Observed stars paired with the projected stars that fall in the image widened by
    ``radius`` (a star just beyond the edge can still be an observed star's)."""
    if frame.grid.cells.ok and 0.0 <= radius < INFINITY:
        return _claimed(frame, projection, radius, -1.0)
    cdef _Selection s = _select(projection, frame.geometry, radius, frame.work)
    cdef Nearest near = nearest_matches(frame.x, frame.y, s.x, s.y, radius, frame.scratch)
    cdef Matches m = Matches.__new__(Matches)
    cdef Py_ssize_t k
    for k in range(near.cat.shape[0]):  # the selection's index to the Stars': in place,
        near.cat[k] = s.where[near.cat[k]]  # the pairing's arrays are this call's own
    m.obs, m.pos, m.n_in = near.obs, near.cat, s.where.shape[0]
    return m


cdef inline Reach _reach(Geometry g, double radius) noexcept:
    """The projected stars a match within ``radius`` takes: those in the image widened by
    it (within()'s window)."""
    cdef _Bounds b = _widened(g, radius)
    cdef Reach r
    r.lo_x, r.hi_x, r.lo_y, r.hi_y, r.radius = b.lo_x, b.hi_x, b.lo_y, b.hi_y, radius
    return r


cdef Matches _claimed(Frame frame, Projection p, double radius, double wide):
    """match_projected on the frame's grid of observed stars (ok; ``radius`` finite):
    the same pairs, with no selection or grid of the projected stars. With ``wide`` >= 0
    (finite) the claims within that radius are made at once and kept for
    :func:`_wide_claimed`."""
    cdef Py_ssize_t n = frame.n, m = p.x.shape[0], wide_in = 0
    cdef NearestScratch scratch = frame.scratch
    cdef VerifyScratch work = frame.work
    scratch.nearest, scratch.dist2 = room_i64(scratch.nearest, n), room_f64(scratch.dist2, n)
    work.wide_nearest = room_i64(work.wide_nearest, n)
    work.wide_dist2 = room_f64(work.wide_dist2, n)
    cdef long long[::1] nearest = scratch.nearest[:n], wide_nearest = work.wide_nearest[:n]
    cdef double[::1] dist2 = scratch.dist2[:n], wide_dist2 = work.wide_dist2[:n]
    nearest[:], dist2[:] = -1, INFINITY
    if wide >= 0.0:
        wide_nearest[:], wide_dist2[:] = -1, INFINITY
    cdef Py_ssize_t n_in = claim_nearest(frame.grid, frame.x, frame.y, p.x, p.y, p.valid,
                                         _reach(frame.geometry, radius), nearest, dist2,
                                         _reach(frame.geometry, wide), wide_nearest,
                                         wide_dist2, &wide_in)
    work.wide_stars, work.wide_in = m if wide >= 0.0 else -1, wide_in
    return _paired(frame, nearest, dist2, m, n_in)


cdef Matches _paired(Frame frame, const long long[::1] nearest, const double[::1] dist2,
                     Py_ssize_t m, Py_ssize_t n_in):
    """The claims (observed star i: projected star ``nearest[i]``), one to one."""
    frame.scratch.owner = room_i64(frame.scratch.owner, m)
    cdef long long[::1] owner = frame.scratch.owner[:m]
    owner[:] = -1
    cdef Nearest near = one_to_one(nearest, dist2, owner)
    cdef Matches out = Matches.__new__(Matches)
    out.obs, out.pos, out.n_in = near.obs, near.cat, n_in
    return out


cdef Matches _wide_claimed(Frame frame, Projection p, double wide):
    """match_projected(frame, p, wide) when the last matching was on ``p`` (from its
    claims when it made them at ``wide``)."""
    if frame.work.wide_stars < 0:
        return match_projected(frame, p, wide)
    return _paired(frame, frame.work.wide_nearest[:frame.n],
                   frame.work.wide_dist2[:frame.n], frame.work.wide_stars,
                   frame.work.wide_in)


cdef Matches _match_pair(Frame frame, Projection p, double radius, double wide):
    """match_projected(frame, p, radius), making the claims at ``wide`` at once where
    the grid serves both."""
    frame.work.wide_stars = -1
    if frame.grid.cells.ok and 0.0 <= radius < INFINITY and 0.0 <= wide < INFINITY:
        return _claimed(frame, p, radius, wide)
    return match_projected(frame, p, radius)


cdef Matches match(Frame frame, const double[:, ::1] vectors, const double[:, :] matrix,
                   double radius):
    return match_projected(frame, _project_into(frame.work.passing, vectors, matrix,
                                                frame.geometry), radius)


cdef Matches match_brightest(Frame frame, const double[:, ::1] vectors,
                             const double[:, :] matrix, double radius, Py_ssize_t max_stars):
    """match() against only the first ``max_stars`` of ``vectors`` (brightest first, as a
    cone's rows are) that fall in the image widened by ``radius``: a frame's brightest
    spots checked against the brightest catalog stars, so that a deep catalog's faint
    stars, which such spots cannot confirm, do not raise the chance of a coincidence."""
    cdef Projection p = _project_into(frame.work.passing, vectors, matrix, frame.geometry)
    cdef _Bounds b = _widened(frame.geometry, radius)
    cdef Py_ssize_t i, inside = 0
    for i in range(p.x.shape[0]):
        if inside >= max_stars:
            p.valid[i] = 0
        elif _inside(&p.x[0], &p.y[0], &p.valid[0], i, b):
            inside += 1
    return match_projected(frame, p, radius)


cdef Py_ssize_t _confirmed(Matches m, const long long[::1] hyp_obs):
    """How many of the matched observed stars are not among ``hyp_obs``."""
    # A hypothesis has a few distinct stars: scanning them beats allocating flags.
    cdef Py_ssize_t k, h, count = 0
    cdef bint chosen
    for k in range(m.obs.shape[0]):
        chosen = False
        for h in range(hyp_obs.shape[0]):
            chosen = chosen or hyp_obs[h] == m.obs[k]
        count += not chosen
    return count
