# The read-out of a frame whose pixels each expect their own electrons: a compiled
# generator (xoshiro256+), exact Poisson (tabulated levels, PTRS) or Gaussian shot noise,
# tabulated normals, and the sensor chain. Included by effects.pyx.

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
