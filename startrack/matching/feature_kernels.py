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

from startrack.database.build_kernels import triangle_features_one

_H = 1e-6  # feature_sigmas' central-difference step


@njit(cache=True, inline="always")
def _cross(u, w):
    return np.array([u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2],
                     u[0] * w[1] - u[1] * w[0]])


@njit(cache=True, inline="always")
def _norm(u):
    return math.sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2])


@njit(cache=True)
def _tangent_basis(v):
    helper = np.zeros(3)
    helper[np.argmin(np.abs(v))] = 1.0
    t1 = _cross(v, helper)
    t1 /= _norm(t1)
    return t1, _cross(v, t1)


@njit(cache=True)
def features(v1, v2, v3, sigma):
    """(area, polar, sigma_area, sigma_polar) of one triple: the database build's own
    :func:`~startrack.database.build_kernels.triangle_features_one`, and first-order
    propagation of ``sigma`` per tangent axis by central differences, as
    ``feature_sigmas``."""
    verts = np.empty((3, 3))
    verts[0], verts[1], verts[2] = v1, v2, v3
    var_a = var_j = 0.0
    for n in range(3):
        v = verts[n].copy()
        for t in _tangent_basis(v):
            verts[n] = v + _H * t
            ap, jp = triangle_features_one(verts, 0, 1, 2)
            verts[n] = v - _H * t
            am, jm = triangle_features_one(verts, 0, 1, 2)
            da, dj = (ap - am) / (2 * _H), (jp - jm) / (2 * _H)
            var_a += da * da
            var_j += dj * dj
        verts[n] = v
    area, polar = triangle_features_one(verts, 0, 1, 2)
    return area, polar, sigma * math.sqrt(var_a), sigma * math.sqrt(var_j)
