# cython: boundscheck=False, wraparound=False, cdivision=True
"""Compiled kernels of the simulator's optics and detector effects: shaped PSF spots
(elliptical Gaussian, Airy, defocus disk) integrated over pixels by sub-sampling,
blooming along columns, and the read-out of a frame whose pixels each expect their own
signal.

Each spot is evaluated on ``oversample x oversample`` points per pixel over its window,
normalised to its electrons over the window (the light a detector edge cuts off is lost),
and added to the image.
"""

from libc.math cimport cos, erfc, exp, fabs, floor, lgamma, log, rint, sqrt
from libc.stdint cimport int32_t, int64_t, uint16_t, uint64_t
from libc.stdlib cimport free, malloc

# The C library's Bessel function of the first kind (POSIX <math.h>): scipy's Cython
# declarations are not in the install's build environment, which has Cython and numpy only.
cdef extern from "math.h" nogil:
    double j1(double x)

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


cdef enum:
    _RADIAL_CELLS = 4096  # a round PSF's profile, tabulated over radius on the spot's window


cdef void _gaussian_stamp(double *stamp, long size, int os, double fx, double fy, double a,
                          double b, double c, double sn) noexcept nogil:
    """An elliptical Gaussian's sub-samples summed per pixel into ``stamp`` (zeroed), its
    first sub-sample at (fx, fy) from the centre. Along a row of sub-samples the exponent
    is quadratic, so each value is the previous times a ratio that itself changes by a
    constant factor: two exps a row instead of one a sub-sample (rows whose first value
    would underflow are evaluated directly)."""
    cdef double qa = -0.5 * (c * c / (a * a) + sn * sn / (b * b))
    cdef double qb = -c * sn * (1.0 / (a * a) - 1.0 / (b * b))
    cdef double qc = -0.5 * (sn * sn / (a * a) + c * c / (b * b))
    cdef double h = 1.0 / os, dy, q0, value, ratio, grow = exp(2.0 * qa * h * h), dx
    cdef long i, si, j, sj, t
    for i in range(size):
        for si in range(os):
            dy = fy + i + si * h
            q0 = qa * fx * fx + qb * fx * dy + qc * dy * dy
            if q0 > -600.0:
                value = exp(q0)
                ratio = exp(2.0 * qa * fx * h + qa * h * h + qb * h * dy)
                for j in range(size):
                    for sj in range(os):
                        stamp[i * size + j] += value
                        value *= ratio
                        ratio *= grow
            else:
                t = 0
                for j in range(size):
                    for sj in range(os):
                        dx = fx + t * h
                        stamp[i * size + j] += exp(qa * dx * dx + qb * dx * dy + qc * dy * dy)
                        t += 1


def deposit_spots(double[:, ::1] image, const double[:, ::1] spots, const int[::1] model,
                  const long[::1] half, const int[::1] oversample):
    """Add each spot's electrons to ``image`` in place, spread by its PSF. ``spots`` has a
    row per spot: x, y, electrons, a, b and the cosine and sine of its axis. Round
    profiles (Airy, defocus) are tabulated over the radius once for each run of spots
    sharing model, sizes and window, and interpolated linearly (within ~1e-5 of the
    peak)."""
    cdef Py_ssize_t n, i, j, si, sj, h = image.shape[0], w = image.shape[1]
    cdef long hw, size, x0, y0, row, col, cell
    cdef int os
    cdef double total, value, dx, dy, step, scale, to_cell = 0.0, f, r
    cdef long biggest = 0
    cdef int table_model = -1
    cdef double table_a = -1.0, table_b = -1.0
    cdef long table_half = -1
    cdef const double[::1] x = spots[:, 0].copy(), y = spots[:, 1].copy()
    cdef const double[::1] electrons = spots[:, 2].copy(), a = spots[:, 3].copy()
    cdef const double[::1] b = spots[:, 4].copy(), cos_axis = spots[:, 5].copy()
    cdef const double[::1] sin_axis = spots[:, 6].copy()
    for n in range(half.shape[0]):
        biggest = max(biggest, half[n])
    cdef double *stamp = <double *> malloc(sizeof(double) * (2 * biggest + 1) ** 2 + 8)
    cdef double *radial = <double *> malloc(sizeof(double) * (_RADIAL_CELLS + 2))
    if stamp == NULL or radial == NULL:
        free(stamp)
        free(radial)
        raise MemoryError()
    try:
        with nogil:
            for n in range(x.shape[0]):
                hw = half[n]
                os = oversample[n]
                step = 1.0 / os
                size = 2 * hw + 1
                x0 = <long>floor(x[n] + 0.5) - hw
                y0 = <long>floor(y[n] + 0.5) - hw
                for i in range(size * size):
                    stamp[i] = 0.0
                if model[n] == 0:
                    _gaussian_stamp(stamp, size, os, x0 - 0.5 + 0.5 * step - x[n],
                                    y0 - 0.5 + 0.5 * step - y[n], a[n], b[n], cos_axis[n],
                                    sin_axis[n])
                else:
                    if (model[n] != table_model or a[n] != table_a or b[n] != table_b
                            or hw != table_half):
                        # sub-samples lie within (hw + 1) * sqrt(2) of the centre
                        to_cell = _RADIAL_CELLS / (_SQRT2 * (hw + 1.0))
                        for cell in range(_RADIAL_CELLS + 2):
                            radial[cell] = _profile(model[n], cell / to_cell, 0.0, a[n], b[n])
                        table_model, table_a, table_b, table_half = model[n], a[n], b[n], hw
                    for i in range(size):
                        for si in range(os):
                            dy = y0 + i - 0.5 + (si + 0.5) * step - y[n]
                            for j in range(size):
                                value = 0.0
                                for sj in range(os):
                                    dx = x0 + j - 0.5 + (sj + 0.5) * step - x[n]
                                    r = sqrt(dx * dx + dy * dy) * to_cell
                                    cell = <long>r
                                    f = r - cell
                                    value += radial[cell] + f * (radial[cell + 1] - radial[cell])
                                stamp[i * size + j] += value
                total = 0.0
                for i in range(size * size):
                    total += stamp[i]
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
        free(radial)


def shade_and_add(double[:, ::1] image, const float[:, ::1] gain, const float[:, ::1] add):
    """``image = image * gain + add`` in one pass (the stars through the PRNU, then the
    frame's background)."""
    cdef Py_ssize_t r, c
    with nogil:
        for r in range(image.shape[0]):
            for c in range(image.shape[1]):
                image[r, c] = image[r, c] * gain[r, c] + add[r, c]


def bloom_columns(double[:, ::1] image, double full_well, const int64_t[::1] columns):
    """Spill the charge above ``full_well`` along each of ``columns`` (those holding an
    overflowing pixel), half up and half down, filling each neighbour to full well before
    passing on; what runs off the edge is lost. Returns the number of pixels that
    overflowed."""
    cdef Py_ssize_t r, c, k, h = image.shape[0]
    cdef double carry, room, take, excess
    cdef long overflowed = 0
    cdef double *up = <double *> malloc(sizeof(double) * h + 8)
    if up == NULL:
        raise MemoryError()
    try:
        with nogil:
            for k in range(columns.shape[0]):
                c = columns[k]
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


include "field_readout.pxi"
