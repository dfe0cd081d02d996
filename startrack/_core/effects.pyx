# cython: boundscheck=False, wraparound=False, cdivision=True
"""Compiled kernels of the simulator's optics and detector effects: shaped PSF spots
(elliptical Gaussian, Airy, defocus disk) integrated over pixels by sub-sampling, and
blooming along columns.

Each spot is evaluated on ``oversample x oversample`` points per pixel over its window,
normalised to its electrons over the window (the light a detector edge cuts off is lost),
and added to the image.
"""

from libc.math cimport erfc, exp, floor, sqrt
from libc.stdlib cimport free, malloc
from scipy.special.cython_special cimport j1

cdef double _SQRT2 = sqrt(2.0)
cdef double _AIRY_ZERO = 3.8317059702075125  # first zero of J1


cdef inline double _profile(int model, double u, double v, double a, double b) noexcept nogil:
    """The PSF at (u, v) (u along the spot's axis): 0 Gaussian (sigmas a along, b across),
    1 Airy (first dark ring at a), 2 disk of radius a softened by a Gaussian of b."""
    cdef double r, x
    if model == 0:
        return exp(-0.5 * ((u / a) * (u / a) + (v / b) * (v / b)))
    r = sqrt(u * u + v * v)
    if model == 1:
        x = _AIRY_ZERO * r / a
        if x < 1e-8:
            return 1.0
        x = 2.0 * j1(x) / x
        return x * x
    return 0.5 * erfc((r - a) / (_SQRT2 * b))


def deposit_spots(double[:, ::1] image, const double[::1] x, const double[::1] y,
                  const double[::1] electrons, const int[::1] model, const double[::1] a,
                  const double[::1] b, const double[::1] cos_axis,
                  const double[::1] sin_axis, const long[::1] half, int oversample):
    """Add each spot's electrons to ``image`` in place, spread by its PSF."""
    cdef Py_ssize_t n, i, j, si, sj, h = image.shape[0], w = image.shape[1]
    cdef long hw, size, x0, y0, row, col
    cdef double total, value, dx, dy, u, v, step = 1.0 / oversample, scale
    cdef long biggest = 0
    for n in range(half.shape[0]):
        biggest = max(biggest, half[n])
    cdef double *stamp = <double *> malloc(sizeof(double) * (2 * biggest + 1) ** 2 + 8)
    if stamp == NULL:
        raise MemoryError()
    try:
        with nogil:
            for n in range(x.shape[0]):
                hw = half[n]
                size = 2 * hw + 1
                x0 = <long>floor(x[n] + 0.5) - hw
                y0 = <long>floor(y[n] + 0.5) - hw
                total = 0.0
                for i in range(size):
                    for j in range(size):
                        value = 0.0
                        for si in range(oversample):
                            dy = y0 + i - 0.5 + (si + 0.5) * step - y[n]
                            for sj in range(oversample):
                                dx = x0 + j - 0.5 + (sj + 0.5) * step - x[n]
                                u = dx * cos_axis[n] + dy * sin_axis[n]
                                v = -dx * sin_axis[n] + dy * cos_axis[n]
                                value += _profile(model[n], u, v, a[n], b[n])
                        stamp[i * size + j] = value
                        total += value
                if total <= 0.0:
                    continue
                scale = electrons[n] / total
                for i in range(size):
                    row = y0 + i
                    if row < 0 or row >= h:
                        continue
                    for j in range(size):
                        col = x0 + j
                        if 0 <= col < w:
                            image[row, col] += stamp[i * size + j] * scale
    finally:
        free(stamp)


def bloom_columns(double[:, ::1] image, double full_well):
    """Spill the charge above ``full_well`` along each column, half up and half down,
    filling each neighbour to full well before passing on; what runs off the edge is lost.
    Returns the number of pixels that overflowed."""
    cdef Py_ssize_t r, c, h = image.shape[0], w = image.shape[1]
    cdef double carry, room, take, excess
    cdef long overflowed = 0
    cdef double *up = <double *> malloc(sizeof(double) * h + 8)
    if up == NULL:
        raise MemoryError()
    try:
        with nogil:
            for c in range(w):
                carry = 0.0
                for r in range(h):  # downward: half of each overflow, then what is carried
                    excess = image[r, c] - full_well
                    if excess > 0.0:
                        overflowed += 1
                        image[r, c] = full_well
                        up[r] = 0.5 * excess
                        carry += 0.5 * excess
                    else:
                        up[r] = 0.0
                        if carry > 0.0:
                            room = full_well - image[r, c]
                            take = carry if carry < room else room
                            image[r, c] += take
                            carry -= take
                carry = 0.0
                for r in range(h - 1, -1, -1):  # upward: the other halves
                    carry += up[r]
                    if carry > 0.0 and up[r] == 0.0:
                        room = full_well - image[r, c]
                        if room > 0.0:
                            take = carry if carry < room else room
                            image[r, c] += take
                            carry -= take
    finally:
        free(up)
    return overflowed
