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


cdef inline double _normal(const double *quantiles, Py_ssize_t m, uint64_t *s) noexcept nogil:
    """A standard normal draw: the normal quantile function, tabulated at m + 1 evenly
    spaced probabilities, interpolated at one uniform; the two outer cells (the tails
    beyond 1/m) are drawn exactly by Marsaglia's (1964) tail method."""
    cdef Py_ssize_t j
    cdef double u = _uniform(s) * m, f, x, a = quantiles[m - 1]
    j = <Py_ssize_t>u
    if 0 < j < m - 1:
        f = u - j
        return quantiles[j] + f * (quantiles[j + 1] - quantiles[j])
    while True:  # the normal beyond a, exactly: x = sqrt(a^2 - 2 log u1) if u2 x < a
        x = sqrt(a * a - 2.0 * log(1.0 - _uniform(s)))
        if _uniform(s) * x < a:
            return -x if j == 0 else x


cdef inline long _poisson_split(double lam, double step, const double *cdf,
                                const int64_t *start, const int32_t *guide,
                                Py_ssize_t buckets, const double *reciprocal,
                                uint64_t *s) noexcept nogil:
    """Poisson(lam) for lam below the tabulated levels, exactly, as Poisson(l) +
    Poisson(lam - l) with l the level below lam on a grid of ``1 / step`` (independent
    Poisson counts add): the first from level l's CDF through its guide table, the second
    (mean d below 1 / step) by the inverse-CDF walk, which a draw below 1 - d <= exp(-d)
    skips (zero) without evaluating exp."""
    cdef Py_ssize_t n = <Py_ssize_t>(lam * step), a
    cdef double d = lam - n / step, u = _uniform(s), p, c
    cdef long j = 0
    a = start[n] + guide[n * buckets + <Py_ssize_t>(u * buckets)]
    while cdf[a] <= u:
        a += 1
    u = _uniform(s)
    if u >= 1.0 - d:
        p = exp(-d)
        c = p
        while c < u and j < 63:
            j += 1
            p *= d * reciprocal[j]
            c += p
    return a - start[n] + j


def field_pixels(const double[::1] expected, uint64_t[::1] state, const double[::1] chain,
                 uint16_t[::1] out, const double[::1] quantiles, const double[::1] reciprocal,
                 const double[::1] cdf, const int64_t[::1] start, const int32_t[::1] guide):
    """Read-out values of a frame whose pixels each expect their own electrons (a
    vignetted, stray-lit, PRNU/DSNU-shaped background), in one pass with a compiled
    generator (xoshiro256+, ``state`` seeded by the caller's numpy Generator).

    Shot noise: a Gaussian of the same mean and variance (unclipped at zero and unrounded:
    neither may shift the mean) wherever the read-out's skewness
    lam / (lam + read_noise^2)^1.5 is below ``skewness`` (the read noise hides the Poisson
    shape; this holds for every lam above 1 / skewness^2), drawn together with the read
    noise (one normal; the non-linearity's mean and slope at lam) for the faint pixels
    (below the tables' reach), else exact Poisson
    (:func:`_poisson_split` on the tables of levels 0, 1 / step, ... below L / step, PTRS
    above). Then full-well clip, ADC non-linearity, Gaussian read noise (:func:`_normal`
    on ``quantiles``), gain, bias and ADC clip. ``chain``: full well, read noise, gain,
    bias, ADC maximum, non-linearity, ``skewness`` and the levels per electron ``step``;
    ``reciprocal[k] = 1 / k``; ``cdf``: the Poisson CDF of each of the L levels over
    k = 0, 1, ... from ``start[n]`` (its last value infinite), ``guide``: L rows of equally
    many buckets, each the first k whose CDF exceeds the bucket's start."""
    cdef double full_well = chain[0], read_noise = chain[1], gain = chain[2]
    cdef double bias = chain[3], adc_max = chain[4], nonlinearity = chain[5]
    cdef double skew_scale = 1.0 / chain[6], step = chain[7]
    cdef double top = (start.shape[0] - 1) / step, inv_gain = 1.0 / gain
    cdef double bend = nonlinearity / full_well, rn2 = read_noise * read_noise
    cdef Py_ssize_t i, buckets = guide.shape[0] // (start.shape[0] - 1)
    cdef Py_ssize_t m = quantiles.shape[0] - 1
    cdef const double *q = &quantiles[0]
    cdef const double *c = &cdf[0]
    cdef const double *rec = &reciprocal[0]
    cdef const int64_t *first = &start[0]
    cdef const int32_t *g = &guide[0]
    cdef double lam, e, adu, g0, total, slope
    # below ``faint`` e- (the Poisson tables' reach, at most half the full well) the
    # full-well clip cannot bite
    cdef double faint = top if top < 0.5 * full_well else 0.5 * full_well
    cdef uint64_t s[4]
    s[0], s[1], s[2], s[3] = state[0], state[1], state[2], state[3]
    with nogil:
        for i in range(expected.shape[0]):
            lam = expected[i] if expected[i] > 0.0 else 0.0
            total = sqrt(lam + rn2)
            if lam < faint and lam * skew_scale < (lam + rn2) * total:
                # shot and read noise as one Gaussian: the non-linearity's mean
                # lam - bend (lam^2 + lam) and slope 1 - 2 bend lam (unclipped: the full
                # well is out of reach)
                if bend != 0.0:
                    slope = 1.0 - 2.0 * bend * lam
                    total = sqrt(lam * slope * slope + rn2)
                e = lam - bend * (lam * lam + lam) + total * _normal(q, m, s)
                adu = rint(e * inv_gain + bias)
                out[i] = <uint16_t>(adu if adu < adc_max else adc_max) if adu > 0.0 else 0
                continue
            g0 = read_noise * _normal(q, m, s) if read_noise > 0.0 else 0.0
            if lam * skew_scale < (lam + rn2) * total:
                e = lam + sqrt(lam) * _normal(q, m, s)
            elif lam < top:
                e = <double>_poisson_split(lam, step, c, first, g, buckets, rec, s)
            else:
                e = <double>_poisson_ptrs(lam, s)
            e = e if e < full_well else full_well
            if nonlinearity != 0.0:
                e = e * (1.0 - bend * e)
            adu = rint((e + g0) * inv_gain + bias)
            out[i] = <uint16_t>(adu if adu < adc_max else adc_max) if adu > 0.0 else 0
    state[0], state[1], state[2], state[3] = s[0], s[1], s[2], s[3]
