# The catalog stars the refit pairs with (included in camera_refit.pyx): the brightest
# that an answer's attitude puts in the image, found by a scan that stops at the last one
# needed, through the camera's own projection.


@cython.cdivision(True)
def brightest_in_view(Optics optics, const double[:, ::1] vectors,
                      const double[:, ::1] matrix, double cos_limit, Py_ssize_t n,
                      const long long[::1] candidates=None):
    """(rows, camera-frame vectors) of the first ``n`` rows of ``vectors`` (a
    brightest-first catalog) that camera-to-sky ``matrix`` puts in ``optics``' image:
    within the angle of cosine ``cos_limit`` of the boresight, in front, inside the
    lens's fold radius and the image (Optics.vector_to_pixel and Camera.in_image, star
    by star, with no product over every star in numpy). ``candidates``: ascending rows
    holding every row within that angle (a cone lookup), scanned in place of them all."""
    cdef Geometry g = optics.geometry
    cdef Lens lens = lens_of(&g)
    cdef bint distorted = not lens_is_identity(&lens)
    rows, out = np.empty(max(n, 0), np.int64), np.empty((max(n, 0), 3))
    cdef long long[::1] r = rows
    cdef double[:, ::1] o = out
    cdef bint some = candidates is not None
    cdef Py_ssize_t i, j, k, found = 0
    cdef Py_ssize_t total = candidates.shape[0] if some else vectors.shape[0]
    cdef double w[3]
    cdef double z, u, t, r2, s, x, y
    for k in range(total if some else 0):
        if not 0 <= candidates[k] < vectors.shape[0]:
            raise IndexError(f"brightest_in_view: candidate row {candidates[k]} out of range")
    with nogil:
        for k in range(total):
            if found >= n:
                break
            i = candidates[k] if some else k
            if (vectors[i, 0] * matrix[0, 2] + vectors[i, 1] * matrix[1, 2]
                    + vectors[i, 2] * matrix[2, 2]) <= cos_limit:
                continue
            for j in range(3):  # sky to camera: the matrix's transpose
                w[j] = (vectors[i, 0] * matrix[0, j] + vectors[i, 1] * matrix[1, j]
                        + vectors[i, 2] * matrix[2, j])
            z = w[2]
            if not z > 1e-12:
                continue
            u, t = w[0] / z, w[1] / z
            if distorted:
                r2 = u * u + t * t
                if not r2 < g.max_r2:
                    continue
                s = lens_factor(&lens, r2)
                u, t = u * s, t * s
            x, y = g.cx + g.f_px * u, g.cy + g.f_px * t
            if x >= -0.5 and x <= g.width - 0.5 and y >= -0.5 and y <= g.height - 0.5:
                r[found] = i
                o[found, 0], o[found, 1], o[found, 2] = w[0], w[1], w[2]
                found += 1
    return rows[:found], out[:found]
