"""Compiled attitude arithmetic: Wahba's problem by Davenport's q-method (a Jacobi
eigen-solve of the 4 x 4 K matrix) and rotation matrix -> quaternion.

These run for every hypothesis a matcher proposes, where numpy's SVD on a 3 x 3 matrix
costs more in call overhead than in arithmetic.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def _rotate(a, v, p, q):
    """One Jacobi rotation of the symmetric 4 x 4 ``a`` zeroing a[p, q], accumulated in v."""
    theta = (a[q, q] - a[p, p]) / (2.0 * a[p, q])
    t = (1.0 if theta >= 0.0 else -1.0) / (abs(theta) + math.sqrt(theta * theta + 1.0))
    c = 1.0 / math.sqrt(t * t + 1.0)
    s = t * c
    for r in range(4):
        arp, arq = a[r, p], a[r, q]
        a[r, p], a[r, q] = c * arp - s * arq, s * arp + c * arq
    for r in range(4):
        apr, aqr = a[p, r], a[q, r]
        a[p, r], a[q, r] = c * apr - s * aqr, s * apr + c * aqr
    for r in range(4):
        vrp, vrq = v[r, p], v[r, q]
        v[r, p], v[r, q] = c * vrp - s * vrq, s * vrp + c * vrq


@njit(cache=True)
def _top_eigenvector(k):
    """The eigenvector of the largest eigenvalue of a symmetric 4 x 4 matrix (cyclic
    Jacobi: accurate to rounding however close the other eigenvalues come, which a
    narrow field makes them)."""
    a = k.copy()
    v = np.eye(4)
    scale = a[0, 0] ** 2 + a[1, 1] ** 2 + a[2, 2] ** 2 + a[3, 3] ** 2
    for _ in range(30):
        off = 0.0
        for p in range(3):
            for q in range(p + 1, 4):
                off += a[p, q] * a[p, q]
        if off <= 1e-30 * scale:
            break
        for p in range(3):
            for q in range(p + 1, 4):
                if a[p, q] != 0.0:
                    _rotate(a, v, p, q)
    best = 0
    for i in range(1, 4):
        if a[i, i] > a[best, best]:
            best = i
    return v[:, best]


@njit(cache=True)
def wahba(cam, sky):
    """The rotation matrix R minimising sum |sky_k - R cam_k|^2 over (m, 3) vector pairs:
    Davenport's q-method, the quaternion maximising q^T K q, by a Jacobi eigen-solve
    (no SVD call: this runs for every hypothesis)."""
    b = np.zeros((3, 3))
    for n in range(cam.shape[0]):
        for i in range(3):
            for j in range(3):
                b[i, j] += sky[n, i] * cam[n, j]
    sigma = b[0, 0] + b[1, 1] + b[2, 2]
    k = np.empty((4, 4))
    k[0, 0] = sigma
    k[0, 1] = k[1, 0] = b[1, 2] - b[2, 1]
    k[0, 2] = k[2, 0] = b[2, 0] - b[0, 2]
    k[0, 3] = k[3, 0] = b[0, 1] - b[1, 0]
    for i in range(3):
        for j in range(3):
            k[i + 1, j + 1] = b[i, j] + b[j, i] - (sigma if i == j else 0.0)
    q = _top_eigenvector(k)
    w, x, y, z = q[0], -q[1], -q[2], -q[3]  # K's vector part is of the inverse rotation
    r = np.empty((3, 3))
    r[0, 0], r[0, 1], r[0, 2] = 1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)
    r[1, 0], r[1, 1], r[1, 2] = 2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)
    r[2, 0], r[2, 1], r[2, 2] = 2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)
    return r


@njit(cache=True)
def matrix_to_quaternion(m):
    """Unit quaternion of a rotation matrix, scalar LAST ``[x, y, z, w]`` as scipy's
    ``Rotation.from_quat`` takes it fastest, w >= 0 (Shepperd's method)."""
    q = np.empty(4)
    tr = m[0, 0] + m[1, 1] + m[2, 2]
    if tr >= m[0, 0] and tr >= m[1, 1] and tr >= m[2, 2]:
        q[0] = 1.0 + tr
        q[1], q[2], q[3] = m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1]
    elif m[0, 0] >= m[1, 1] and m[0, 0] >= m[2, 2]:
        q[0], q[1] = m[2, 1] - m[1, 2], 1.0 + 2.0 * m[0, 0] - tr
        q[2], q[3] = m[0, 1] + m[1, 0], m[0, 2] + m[2, 0]
    elif m[1, 1] >= m[2, 2]:
        q[0], q[1] = m[0, 2] - m[2, 0], m[0, 1] + m[1, 0]
        q[2], q[3] = 1.0 + 2.0 * m[1, 1] - tr, m[1, 2] + m[2, 1]
    else:
        q[0], q[1] = m[1, 0] - m[0, 1], m[0, 2] + m[2, 0]
        q[2], q[3] = m[1, 2] + m[2, 1], 1.0 + 2.0 * m[2, 2] - tr
    q /= np.sqrt((q * q).sum())
    if q[0] < 0.0:
        q = -q
    return np.array([q[1], q[2], q[3], q[0]])
