"""Compiled per-pixel noise of the renderer: shot noise, full well, read noise and the ADC.

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
def _cdf_table(lam, table):
    """Poisson(lam) CDF at k = 0 .. len(table) - 1 into ``table``."""
    p = math.exp(-lam)
    cdf = p
    for k in range(len(table)):
        table[k] = cdf
        p *= lam / (k + 1)
        cdf += p


@njit(cache=True)
def shot_noise(expected, uniform, out):
    """Electrons per pixel into ``out`` (float32), from one uniform draw per pixel.

    Pixels that numpy must draw are marked: -1 for exact Poisson (mid range, few: star
    cores), -2 for the Gaussian (above ``GAUSS_ABOVE``).
    """
    h, w = expected.shape
    table = np.empty(256)
    last_lam, n_tab = -1.0, 0
    for r in range(h):
        for c in range(w):
            lam = max(float(expected[r, c]), 0.0)
            if lam < _EXACT_BELOW:
                if lam != last_lam:  # flat backgrounds repeat one mean: one table
                    last_lam = lam
                    _cdf_table(lam, table)
                    n_tab = 0  # entries that a float32 uniform (< 1 - 2^-25) can exceed
                    while n_tab < 255 and table[n_tab] < 1.0 - 2.0**-25:
                        n_tab += 1
                u, k = uniform[r, c], 0
                if n_tab <= 32:  # count, without branches: the table is increasing
                    for i in range(n_tab):
                        k += table[i] < u
                else:
                    while k < 255 and table[k] < u:
                        k += 1
                if k == 255:  # beyond the table (u within ~1e-16 of 1): walk on
                    k = _poisson_inverse(lam, math.exp(-lam), u)
                out[r, c] = k
            else:
                out[r, c] = -2.0 if lam >= GAUSS_ABOVE else -1.0


@njit(cache=True)
def readout(electrons, normal, full_well, read_noise, gain, bias, adc_max, out):
    """Full-well clip, read noise, gain, bias, rounding and ADC clip into ``out`` (uint16)."""
    h, w = electrons.shape
    for r in range(h):
        for c in range(w):
            e = min(electrons[r, c], full_well) + read_noise * normal[r, c]
            adu = np.rint(e / gain + bias)
            out[r, c] = min(max(adu, 0.0), adc_max)
