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
from libc.stdint cimport int64_t, uint16_t, uint64_t
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


def deposit_spots(double[:, ::1] image, const double[:, ::1] spots, const int[::1] model,
                  const long[::1] half, const int[::1] oversample):
    """Add each spot's electrons to ``image`` in place, spread by its PSF. ``spots`` has a
    row per spot: x, y, electrons, a, b and the cosine and sine of its axis."""
    cdef Py_ssize_t n, i, j, si, sj, h = image.shape[0], w = image.shape[1]
    cdef long hw, size, x0, y0, row, col
    cdef int os
    cdef double total, value, dx, dy, u, v, step, scale
    cdef long biggest = 0
    cdef const double[::1] x = spots[:, 0].copy(), y = spots[:, 1].copy()
    cdef const double[::1] electrons = spots[:, 2].copy(), a = spots[:, 3].copy()
    cdef const double[::1] b = spots[:, 4].copy(), cos_axis = spots[:, 5].copy()
    cdef const double[::1] sin_axis = spots[:, 6].copy()
    for n in range(half.shape[0]):
        biggest = max(biggest, half[n])
    cdef double *stamp = <double *> malloc(sizeof(double) * (2 * biggest + 1) ** 2 + 8)
    if stamp == NULL:
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
                total = 0.0
                for i in range(size):
                    for j in range(size):
                        value = 0.0
                        for si in range(os):
                            dy = y0 + i - 0.5 + (si + 0.5) * step - y[n]
                            for sj in range(os):
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


cdef double _TO_UNIT = 2.0 ** -53
cdef double _TWO_PI = 6.283185307179586


cdef inline double _uniform(uint64_t *s) noexcept nogil:
    """xoshiro256+ in [0, 1): the state's four words, stepped in place."""
    cdef uint64_t result = s[0] + s[3], t = s[1] << 17
    s[2] ^= s[0]
    s[3] ^= s[1]
    s[1] ^= s[2]
    s[0] ^= s[3]
    s[2] ^= t
    s[3] = (s[3] << 45) | (s[3] >> 19)
    return <double>(result >> 11) * _TO_UNIT


cdef inline long _poisson_ptrs(double lam, uint64_t *s) noexcept nogil:
    """Poisson(lam) for lam >= 10 by Hoermann's transformed rejection (PTRS, 1993; numpy's
    method too): exact, about 1.2 pairs of uniforms a draw."""
    cdef double slam = sqrt(lam), loglam = log(lam)
    cdef double b = 0.931 + 2.53 * slam, a = -0.059 + 0.02483 * b
    cdef double invalpha = 1.1239 + 1.1328 / (b - 3.4), vr = 0.9277 - 3.6224 / (b - 2.0)
    cdef double u, v, us
    cdef long k
    while True:
        u = _uniform(s) - 0.5
        v = _uniform(s)
        us = 0.5 - fabs(u)
        k = <long>floor((2.0 * a / us + b) * u + lam + 0.43)
        if us >= 0.07 and v <= vr:
            return k
        if k < 0 or (us < 0.013 and v > us):
            continue
        if (log(v) + log(invalpha) - log(a / (us * us) + b)
                <= -lam + k * loglam - lgamma(k + 1.0)):
            return k


cdef inline double _normal(const double[::1] quantiles, uint64_t *s) noexcept nogil:
    """A standard normal draw: the normal quantile function, tabulated at m + 1 evenly
    spaced probabilities, interpolated at one uniform; the two outer cells (the tails
    beyond 1/m) are drawn exactly by Marsaglia's (1964) tail method."""
    cdef Py_ssize_t m = quantiles.shape[0] - 1, j
    cdef double u = _uniform(s) * m, f, x, a = quantiles[m - 1]
    j = <Py_ssize_t>u
    if 0 < j < m - 1:
        f = u - j
        return quantiles[j] + f * (quantiles[j + 1] - quantiles[j])
    while True:  # the normal beyond a, exactly: x = sqrt(a^2 - 2 log u1) if u2 x < a
        x = sqrt(a * a - 2.0 * log(1.0 - _uniform(s)))
        if _uniform(s) * x < a:
            return -x if j == 0 else x


def field_pixels(const double[::1] expected, uint64_t[::1] state, const double[::1] chain,
                 uint16_t[::1] out, const double[::1] quantiles, const double[::1] reciprocal):
    """Read-out values of a frame whose pixels each expect their own electrons (a
    vignetted, stray-lit, PRNU/DSNU-shaped background), in one pass with a compiled
    generator (xoshiro256+, ``state`` seeded by the caller's numpy Generator): shot noise
    exact Poisson below ``gauss_above`` (inverse CDF below 10 e-, PTRS above) and Gaussian
    above, full-well clip, ADC non-linearity, Gaussian read noise (:func:`_normal` on
    ``quantiles``), gain, bias and ADC clip. ``chain``: full well, read noise, gain,
    bias, ADC maximum, non-linearity and ``gauss_above``; ``reciprocal[k] = 1 / k``."""
    cdef double full_well = chain[0], read_noise = chain[1], gain = chain[2]
    cdef double bias = chain[3], adc_max = chain[4], nonlinearity = chain[5]
    cdef double gauss_above = chain[6]
    cdef Py_ssize_t i
    cdef double lam, e, p, cdf, u, adu, g0
    cdef long k
    cdef uint64_t s[4]
    s[0], s[1], s[2], s[3] = state[0], state[1], state[2], state[3]
    with nogil:
        for i in range(expected.shape[0]):
            lam = expected[i] if expected[i] > 0.0 else 0.0
            g0 = _normal(quantiles, s) if read_noise > 0.0 else 0.0
            if lam < 10.0:
                u = _uniform(s)
                p = exp(-lam)
                cdf, k = p, 0
                while cdf < u and k < 63:
                    k += 1
                    p *= lam * reciprocal[k]
                    cdf += p
                e = <double>k
            elif lam < gauss_above:
                e = <double>_poisson_ptrs(lam, s)
            else:
                e = rint(lam + sqrt(lam) * _normal(quantiles, s))
                e = e if e > 0.0 else 0.0
            e = e if e < full_well else full_well
            if nonlinearity != 0.0:
                e = e * (1.0 - nonlinearity * e / full_well)
            adu = rint((e + read_noise * g0) / gain + bias)
            out[i] = <uint16_t>(adu if adu < adc_max else adc_max) if adu > 0.0 else 0
    state[0], state[1], state[2], state[3] = s[0], s[1], s[2], s[3]
