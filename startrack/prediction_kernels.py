"""Compiled kernels of the attitude prediction: the next frame's attitude and its error
from the last two solved ones, and rotation matrix <-> rotation vector (numba: scipy's
Rotation costs tens of microseconds a call, more than the arithmetic).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def predict_attitude(rot_a, rot_b, gap, steps, sig_a, sig_b, unknown_rate, accel_fraction,
                     rate_floor):
    """The attitude ``steps`` frames after ``rot_b`` (camera to sky) and its 1-sigma error:
    the per-frame rotation estimated from ``rot_a``, ``gap`` frames before ``rot_b``
    (R_b = R_a exp(w gap), in the camera frame), carried forward; with ``gap`` 0 there is
    no rate yet and the error grows by ``unknown_rate`` per frame. The rate's own error
    per frame: the two attitudes' errors over the gap, ``accel_fraction`` of the rate
    (angular acceleration) and a floor (jitter)."""
    rate = np.zeros(3)
    sig_w = unknown_rate
    if gap > 0:
        rate = rotation_log(_mul(rot_a.T, rot_b)) / gap
        sig_w = (math.hypot(sig_a, sig_b) / gap + accel_fraction * np.linalg.norm(rate)
                 + rate_floor)
    return _mul(rot_b, rotation_exp(rate * steps)), sig_b + steps * sig_w


@njit(cache=True)
def _mul(a, b):
    """a @ b for 3 x 3 matrices, written out (numba's @ calls BLAS, whose call costs
    more than nine dot products)."""
    out = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            out[i, j] = a[i, 0] * b[0, j] + a[i, 1] * b[1, j] + a[i, 2] * b[2, j]
    return out


@njit(cache=True)
def rotation_exp(rotvec: np.ndarray) -> np.ndarray:
    """The rotation matrix of a rotation vector (Rodrigues), without scipy's overhead."""
    angle = float(np.linalg.norm(rotvec))
    if angle < 1e-15:
        return np.eye(3)
    k = rotvec / angle
    kx = np.zeros((3, 3))
    kx[0, 1], kx[0, 2], kx[1, 2] = -k[2], k[1], -k[0]
    kx[1, 0], kx[2, 0], kx[2, 1] = k[2], -k[1], k[0]
    return np.eye(3) + math.sin(angle) * kx + (1.0 - math.cos(angle)) * _mul(kx, kx)


@njit(cache=True)
def rotation_log(matrix: np.ndarray) -> np.ndarray:
    """The rotation vector of a rotation matrix (angles well below pi: frame to frame)."""
    cos = min(1.0, max(-1.0, (float(np.trace(matrix)) - 1.0) / 2.0))
    angle = math.acos(cos)
    axis = np.empty(3)
    axis[0] = matrix[2, 1] - matrix[1, 2]
    axis[1] = matrix[0, 2] - matrix[2, 0]
    axis[2] = matrix[1, 0] - matrix[0, 1]
    if angle < 1e-7:
        return axis / 2.0
    return axis * (angle / (2.0 * math.sin(angle)))


def warm_up() -> None:
    """Compile (or load from numba's cache) the kernels before any timed frame."""
    m = rotation_exp(np.array([0.0, 0.0, 0.1]))
    rotation_log(m)
    predict_attitude(m, m, 1, 1, 1e-5, 1e-5, 1e-3, 0.1, 1e-4)
