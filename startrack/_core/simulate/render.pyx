"""Per-pixel noise of the renderer: shot noise, full well, read noise and the ADC.

Pixels that expect the frame's common sky value are drawn in one step from the exact
distribution of their read-out value (``sky_pixels``, tables from ``render_noise``);
the others go through the chain below.

Shot noise is exact Poisson below ``GAUSS_ABOVE`` electrons (inverse CDF of a uniform
draw, the recursion p(k + 1) = p(k) * lam / (k + 1)), and a Gaussian of the same mean and
variance above it, where the Poisson skewness 1 / sqrt(lam) is below 0.03 and the
full-well clip soon takes over. The random numbers come from the caller's seeded numpy
Generator (uniforms and normals as arrays), so frames are reproducible.
"""

from libc.math cimport exp, rint
from libc.stdint cimport int64_t, uint16_t, uint64_t

GAUSS_ABOVE = 1000.0
cdef double _GAUSS_ABOVE = GAUSS_ABOVE
cdef double _EXACT_BELOW = 60.0  # inverse-CDF walk: ~lam steps; the rest is numpy's
cdef double _TO_UNIT = 2.0 ** -53

ctypedef fused real_t:
    float
    double


cdef class Readout:
    """The read-out chain of a pixel: full-well clip (electrons), read noise (electrons
    rms), gain (electrons per ADU), bias (ADU), the ADC's largest value (ADU) and its
    non-linearity (the signal ``e`` reads as ``e (1 - nonlinearity e / full_well)``)."""

    cdef readonly double full_well, read_noise, gain, bias, adc_max, nonlinearity

    def __init__(self, double full_well, double read_noise, double gain, double bias,
                 double adc_max, double nonlinearity=0.0):
        self.full_well, self.read_noise, self.gain = full_well, read_noise, gain
        self.bias, self.adc_max, self.nonlinearity = bias, adc_max, nonlinearity


cdef long _poisson_inverse(double lam, double p0, double u) noexcept nogil:
    """Smallest k with CDF(k) >= u for Poisson(lam); p0 = exp(-lam)."""
    cdef long k = 0
    cdef double p = p0, cdf = p0
    while cdf < u and k < 10_000:
        k += 1
        p *= lam / k
        cdf += p
        if p == 0.0 and k > lam:  # the tail below double precision: u was ~1
            break
    return k


def shot_noise(const real_t[::1] expected, const double[::1] uniform, float[::1] out):
    """Electrons per pixel into ``out``, from one uniform draw per pixel. Pixels that numpy
    must draw are marked: -1 for exact Poisson (mid range, few: star cores), -2 for the
    Gaussian (above ``GAUSS_ABOVE``)."""
    cdef Py_ssize_t i
    cdef double lam
    with nogil:
        for i in range(expected.shape[0]):
            lam = max(<double>expected[i], 0.0)
            if lam < _EXACT_BELOW:  # the walk takes about lam steps
                out[i] = _poisson_inverse(lam, exp(-lam), uniform[i])
            else:
                out[i] = -2.0 if lam >= _GAUSS_ABOVE else -1.0


def readout(const float[::1] electrons, const float[::1] normal, Readout chain,
            uint16_t[::1] out, const int64_t[::1] where):
    """Full-well clip, read noise, gain, bias, rounding and ADC clip into ``out[where]``."""
    cdef Py_ssize_t i
    cdef double e, adu
    with nogil:
        for i in range(electrons.shape[0]):
            e = min(<double>electrons[i], chain.full_well)
            if chain.nonlinearity != 0.0:
                e = e * (1.0 - chain.nonlinearity * e / chain.full_well)
            e = e + chain.read_noise * normal[i]
            adu = rint(e / chain.gain + chain.bias)
            out[where[i]] = <uint16_t>min(max(adu, 0.0), chain.adc_max)


cdef class SkyTable:
    """The read-out distribution of a pixel expecting the sky's ``lam`` electrons: CDF over
    ADU values a0, a0 + 1, ... (``render_noise.adu_table``), its guide table and a0."""

    cdef readonly double lam
    cdef readonly object cdf, guide
    cdef readonly long a0

    def __init__(self, double lam, cdf, guide, long a0):
        self.lam, self.cdf, self.guide, self.a0 = lam, cdf, guide, a0


def sky_pixels(const real_t[::1] expected, Py_ssize_t start, Py_ssize_t stop, SkyTable table,
               uint64_t[::1] state, uint16_t[::1] out, int64_t[::1] others):
    """Read-out values of the pixels ``start .. stop - 1`` that expect ``table.lam``.

    Each takes the ADU value at which the CDF first exceeds its uniform draw, from
    xoshiro256+ (``state``: 4 uint64 seeded by the caller's numpy Generator, carried on
    in place); the indices of the other pixels go to ``others``, and their count is
    returned."""
    cdef const double[::1] cdf = table.cdf
    cdef const int64_t[::1] guide = table.guide
    cdef real_t lam = <real_t>table.lam
    cdef Py_ssize_t i, a, m = guide.shape[0], n = 0
    cdef uint64_t s0 = state[0], s1 = state[1], s2 = state[2], s3 = state[3], t
    cdef double u
    with nogil:
        for i in range(start, stop):
            if expected[i] == lam:
                u = <double>((s0 + s3) >> 11) * _TO_UNIT
                t = s1 << 17  # xoshiro256+ step, in registers
                s2 ^= s0
                s3 ^= s1
                s1 ^= s2
                s0 ^= s3
                s2 ^= t
                s3 = (s3 << 45) | (s3 >> 19)
                a = guide[<Py_ssize_t>(u * m)]
                while cdf[a] <= u:
                    a += 1
                out[i] = <uint16_t>(table.a0 + a)
            else:
                others[n] = i
                n += 1
    state[0], state[1], state[2], state[3] = s0, s1, s2, s3
    return n
