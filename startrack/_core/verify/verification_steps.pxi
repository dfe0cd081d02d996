# The steps of verification (included in verification.pyx): the frame and catalog records, the
# projection and the Wahba fit (the pairing: verification_match.pxi).


cdef class Frame:
    def __init__(self, const double[:, ::1] vectors, const double[::1] x,
                 const double[::1] y, const double[::1] flux, Geometry geometry):
        _fill_frame(self, vectors, x, y, flux, &geometry)


cdef Frame new_frame(const double[:, ::1] vectors, const double[::1] x, const double[::1] y,
                     const double[::1] flux, const Geometry* geometry):
    """A Frame made in C: its ``__init__`` takes the camera as a Python dict, and the
    struct's conversion both ways cost a tracked frame more than its matching."""
    cdef Frame frame = Frame.__new__(Frame)
    _fill_frame(frame, vectors, x, y, flux, geometry)
    return frame


cdef void _fill_frame(Frame frame, const double[:, ::1] vectors, const double[::1] x,
                      const double[::1] y, const double[::1] flux,
                      const Geometry* geometry) except *:
    if not (vectors.shape[0] == x.shape[0] == y.shape[0] == flux.shape[0]):
        raise ValueError("Frame: observed arrays of unequal lengths")
    frame.vectors, frame.x, frame.y, frame.flux = vectors, x, y, flux
    frame.geometry = geometry[0]
    frame.n = x.shape[0]
    frame.scratch = _thread_scratch()
    frame.work = _thread_work()
    frame.grid = point_grid(x, y)


# Each thread's matching buffers, shared by the frames it checks: a new frame (one per
# verified camera in a focal-length search) would otherwise allocate them all again. A
# call sets every value it reads and returns fresh arrays, so sharing them is safe; per
# thread, as a call may let another thread run (a finalizer's bytecode).
_THREAD = threading.local()


cdef NearestScratch _thread_scratch():
    cdef NearestScratch scratch = getattr(_THREAD, "scratch", None)
    if scratch is None:
        scratch = _THREAD.scratch = NearestScratch.__new__(NearestScratch)
    return scratch


cdef VerifyScratch _thread_work():
    cdef VerifyScratch work = getattr(_THREAD, "work", None)
    if work is None:
        work = _THREAD.work = VerifyScratch.__new__(VerifyScratch)
        work.kept, work.passing = _projection_buffer(), _projection_buffer()
    return work


cdef ProjectionBuffer _projection_buffer():
    cdef ProjectionBuffer b = ProjectionBuffer.__new__(ProjectionBuffer)
    b.view = Projection.__new__(Projection)
    return b


cdef double[:, ::1] _cam_rows(Frame frame, Py_ssize_t m):
    """The first ``m`` rows of the frame's scratch for observed vectors (unset values)."""
    frame.work.cam = room_rows(frame.work.cam, m)
    return frame.work.cam[:m]


cdef double[:, ::1] _sky_rows(Frame frame, Py_ssize_t m):
    """The first ``m`` rows of the frame's scratch for catalog vectors (unset values)."""
    frame.work.sky = room_rows(frame.work.sky, m)
    return frame.work.sky[:m]


cdef class Stars:
    def __init__(self, const double[:, ::1] vectors, const double[::1] mags,
                 const long long[::1] rows):
        if not (vectors.shape[0] == mags.shape[0] == rows.shape[0]):
            raise ValueError("Stars: catalog arrays of unequal lengths")
        self.vectors, self.mags, self.rows = vectors, mags, rows


cdef Stars _gather(const double[:, ::1] catalog, const double[::1] mags,
                  const long long[::1] r, VerifyScratch work):
    """The catalog stars of rows ``r`` as Stars, in ``work``'s cone buffers."""
    cdef Py_ssize_t m = r.shape[0], i
    cdef Stars out = Stars.__new__(Stars)
    work.cone_vectors = room_rows(work.cone_vectors, m)
    work.cone_mags = room_f64(work.cone_mags, m)
    cdef double[:, ::1] vectors = work.cone_vectors[:m]
    cdef double[::1] row_mags = work.cone_mags[:m]
    for i in range(m):
        vectors[i, 0], vectors[i, 1], vectors[i, 2] = (catalog[r[i], 0], catalog[r[i], 1],
                                                       catalog[r[i], 2])
        row_mags[i] = mags[r[i]]
    out.vectors, out.mags, out.rows = vectors, row_mags, r
    return out


cdef class Matches:
    def __iter__(self):
        """(observed index, positions, catalog stars in the widened image)."""
        return iter((np.asarray(self.obs), np.asarray(self.pos), self.n_in))


cdef bint _same(Matches a, Matches b) noexcept:
    """Whether two match lists are the same pairs in the same order."""
    return _same_pairs(a.obs, a.pos, b)


cdef bint _same_pairs(const long long[::1] obs, const long long[::1] pos,
                      Matches b) noexcept:
    """Whether the pairs (``obs[k]``, ``pos[k]``) are those of ``b`` (False: None), in
    the same order."""
    cdef Py_ssize_t k
    if b is None or obs.shape[0] != b.obs.shape[0]:
        return False
    for k in range(obs.shape[0]):
        if obs[k] != b.obs[k] or pos[k] != b.pos[k]:
            return False
    return True


cdef Projection project(const double[:, ::1] vectors, const double[:, :] matrix,
                        Geometry g):
    """Pixel positions of catalog vectors (n, 3) at the attitude ``matrix`` (camera to
    sky); a star behind the camera, or beyond the radius where the lens folds back, has
    none."""
    cdef Py_ssize_t n = vectors.shape[0]
    cdef Projection p = Projection.__new__(Projection)
    p.x, p.y, p.valid = empty_f64(n), empty_f64(n), zeros_u8(n)
    _fill(vectors, matrix, g, p)
    return p


cdef Projection _project_into(ProjectionBuffer buf, const double[:, ::1] vectors,
                              const double[:, :] matrix, Geometry g):
    """project() in ``buf``'s arrays: valid until the buffer's next call."""
    cdef Py_ssize_t n = vectors.shape[0]
    buf.x, buf.y, buf.valid = room_f64(buf.x, n), room_f64(buf.y, n), room_u8(buf.valid, n)
    buf.view.x, buf.view.y, buf.view.valid = buf.x[:n], buf.y[:n], buf.valid[:n]
    _fill(vectors, matrix, g, buf.view)
    return buf.view


@cython.cdivision(True)  # vz > 1e-12 where it divides
cdef void _fill(const double[:, ::1] vectors, const double[:, :] matrix, Geometry g,
                Projection p) noexcept:
    """Every value of ``p``: the projection, 0 and not valid where there is none."""
    cdef Py_ssize_t n = vectors.shape[0], row = vectors.shape[1], i
    cdef double a, b, c, vx, vy, vz, u, w, r2, s
    if n == 0:
        return
    # the attitude's values and the outputs' pointers in locals: the loop's stores could
    # otherwise alias them, and each would be loaded again per star
    cdef double m00 = matrix[0, 0], m01 = matrix[0, 1], m02 = matrix[0, 2]
    cdef double m10 = matrix[1, 0], m11 = matrix[1, 1], m12 = matrix[1, 2]
    cdef double m20 = matrix[2, 0], m21 = matrix[2, 1], m22 = matrix[2, 2]
    cdef const double* v = &vectors[0, 0]
    cdef double* x = &p.x[0]
    cdef double* y = &p.y[0]
    cdef unsigned char* valid = &p.valid[0]
    for i in range(n):
        x[i], y[i], valid[i] = 0.0, 0.0, False
        a, b, c = v[row * i], v[row * i + 1], v[row * i + 2]  # R^T v: in the camera frame
        vx = a * m00 + b * m10 + c * m20
        vy = a * m01 + b * m11 + c * m21
        vz = a * m02 + b * m12 + c * m22
        if vz <= 1e-12:
            continue
        u, w = vx / vz, vy / vz
        r2 = u * u + w * w
        if not r2 < g.max_r2:
            continue
        s = 1.0 + r2 * (g.k1 + r2 * (g.k2 + r2 * g.k3))
        x[i], y[i] = g.cx + g.f_px * (u * s), g.cy + g.f_px * (w * s)
        valid[i] = True


cdef bint fits_within(const double[:, :] cam, const double[:, :] sky,
                      const double[:, :] matrix, double cos_radius) noexcept nogil:
    """Whether every pair lies within the match radius of the other at ``matrix``."""
    cdef Py_ssize_t k
    cdef int i
    cdef double dot
    for k in range(cam.shape[0]):
        dot = 0.0
        for i in range(3):
            dot += (matrix[i, 0] * cam[k, 0] + matrix[i, 1] * cam[k, 1]
                    + matrix[i, 2] * cam[k, 2]) * sky[k, i]
        if dot < cos_radius:
            return False
    return True


cdef double[:, ::1] _fit(Frame frame, const long long[::1] obs,
                         const double[:, ::1] vectors, const long long[::1] pos):
    """The Wahba attitude of the frame's observed ``obs[k]`` on catalog vector
    ``pos[k]``."""
    cdef Py_ssize_t m = obs.shape[0], k
    cdef const double[:, ::1] obs_vectors = frame.vectors
    cdef double[:, ::1] cam = _cam_rows(frame, m), sky = _sky_rows(frame, m)
    cdef double[:, ::1] r = empty_rows(3, 3)
    for k in range(m):
        cam[k, 0], cam[k, 1], cam[k, 2] = (obs_vectors[obs[k], 0], obs_vectors[obs[k], 1],
                                           obs_vectors[obs[k], 2])
        sky[k, 0], sky[k, 1], sky[k, 2] = (vectors[pos[k], 0], vectors[pos[k], 1],
                                           vectors[pos[k], 2])
    wahba(cam, sky, r)
    return r
