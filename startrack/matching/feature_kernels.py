"""Planar-triangle features of one observed triple, compiled and to the bit the numbers of
:func:`startrack.database.triangles.triangle_features` and
:func:`~startrack.database.triangles.feature_sigmas`: the same operations in the same
order (numpy's norm along an axis sums the squares in order), so that a search that
computes them triple by triple, only for the triples it looks up, looks up the same
windows as the batch (tests/test_triangle_search.py holds them equal on numpy 1.26 and 2).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

_H = 1e-6  # feature_sigmas' central-difference step


@njit(cache=True, inline="always")
def _cross(u, w):
    return np.array([u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2],
                     u[0] * w[1] - u[1] * w[0]])


@njit(cache=True, inline="always")
def _norm(u):
    return math.sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2])


@njit(cache=True)
def area_polar(v1, v2, v3):
    """(area, polar moment) of the planar triangle through unit vectors v1, v2, v3."""
    area = 0.5 * _norm(_cross(v2 - v1, v3 - v1))
    a, b, c = _norm(v1 - v2), _norm(v2 - v3), _norm(v1 - v3)
    return area, area * (a * a + b * b + c * c) / 36.0


@njit(cache=True)
def _tangent_basis(v):
    helper = np.zeros(3)
    helper[np.argmin(np.abs(v))] = 1.0
    t1 = _cross(v, helper)
    t1 /= _norm(t1)
    return t1, _cross(v, t1)


@njit(cache=True)
def features(v1, v2, v3, sigma):
    """(area, polar, sigma_area, sigma_polar) of one triple: first-order propagation of
    ``sigma`` per tangent axis by central differences, as ``feature_sigmas``."""
    verts = (v1, v2, v3)
    var_a = var_j = 0.0
    for n in range(3):
        t1, t2 = _tangent_basis(verts[n])
        for t in (t1, t2):
            plus, minus = verts[n] + _H * t, verts[n] - _H * t
            if n == 0:
                ap, jp = area_polar(plus, v2, v3)
                am, jm = area_polar(minus, v2, v3)
            elif n == 1:
                ap, jp = area_polar(v1, plus, v3)
                am, jm = area_polar(v1, minus, v3)
            else:
                ap, jp = area_polar(v1, v2, plus)
                am, jm = area_polar(v1, v2, minus)
            da, dj = (ap - am) / (2 * _H), (jp - jm) / (2 * _H)
            var_a += da * da
            var_j += dj * dj
    area, polar = area_polar(v1, v2, v3)
    return area, polar, sigma * math.sqrt(var_a), sigma * math.sqrt(var_j)
