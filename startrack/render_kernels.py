"""Compiled per-pixel noise of the renderer: shot noise, full well, read noise and the ADC.

Pixels that expect the frame's common sky value are drawn in one step from the exact
distribution of their read-out value (``sky_pixels``, tables from ``render_noise``);
the others go through the chain below.

Shot noise is exact Poisson below ``GAUSS_ABOVE`` electrons (inverse CDF of a uniform
draw, the recursion p(k + 1) = p(k) * lam / (k + 1)), and a Gaussian of the same mean and
variance above it, where the Poisson skewness 1 / sqrt(lam) is below 0.03 and the
full-well clip soon takes over. The random numbers come from the caller's seeded numpy
Generator (uniforms and normals as arrays), so frames are reproducible.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

GAUSS_ABOVE = 1000.0
_EXACT_BELOW = 60.0  # inverse-CDF walk: ~lam steps; the rest of the exact range is numpy's


@njit(cache=True)
def _poisson_inverse(lam, p0, u):
    """Smallest k with CDF(k) >= u for Poisson(lam); p0 = exp(-lam)."""
    k, p = 0, p0
    cdf = p
    while cdf < u and k < 10_000:
        k += 1
        p *= lam / k
        cdf += p
        if p == 0.0 and k > lam:  # the tail below double precision: u was ~1
            break
    return k


@njit(cache=True)
def shot_noise(expected, uniform, out):
    """Electrons per pixel into ``out`` (1-D, float32), from one uniform draw per pixel.

    Pixels that numpy must draw are marked: -1 for exact Poisson (mid range, few: star
    cores), -2 for the Gaussian (above ``GAUSS_ABOVE``).
    """
    for i in range(expected.shape[0]):
        lam = max(float(expected[i]), 0.0)
        if lam < _EXACT_BELOW:  # the walk takes about lam steps
            out[i] = _poisson_inverse(lam, math.exp(-lam), uniform[i])
        else:
            out[i] = -2.0 if lam >= GAUSS_ABOVE else -1.0


@njit(cache=True)
def readout(electrons, normal, full_well, read_noise, gain, bias, adc_max, out, where):
    """Full-well clip, read noise, gain, bias, rounding and ADC clip into ``out[where]``."""
    for i in range(electrons.shape[0]):
        e = min(electrons[i], full_well) + read_noise * normal[i]
        adu = np.rint(e / gain + bias)
        out[where[i]] = min(max(adu, 0.0), adc_max)


_U11, _U17, _U45, _U19 = np.uint64(11), np.uint64(17), np.uint64(45), np.uint64(19)
_TO_UNIT = 2.0**-53


@njit(cache=True)
def sky_pixels(expected, start, stop, lam, state, cdf, guide, a0, out, others):
    """Read-out values of the pixels ``start .. stop - 1`` that expect ``lam`` electrons.

    Each takes the ADU value at which the distribution's CDF (``adu_table``) first
    exceeds its uniform draw, from xoshiro256+ (``state``: 4 uint64 seeded by the
    caller's numpy Generator, carried on in place); the indices of the other pixels go
    to ``others``, and their count is returned.
    """
    m, n = len(guide), 0
    s0, s1, s2, s3 = state[0], state[1], state[2], state[3]
    for i in range(start, stop):
        if expected[i] == lam:
            u = float((s0 + s3) >> _U11) * _TO_UNIT
            t = s1 << _U17  # xoshiro256+ step, in registers
            s2 ^= s0
            s3 ^= s1
            s1 ^= s2
            s0 ^= s3
            s2 ^= t
            s3 = (s3 << _U45) | (s3 >> _U19)
            a = guide[int(u * m)]
            while cdf[a] <= u:
                a += 1
            out[i] = a0 + a
        else:
            others[n] = i
            n += 1
    state[0], state[1], state[2], state[3] = s0, s1, s2, s3
    return n
