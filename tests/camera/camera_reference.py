"""The camera model in numpy, as startrack.camera and startrack.camera._distortion computed it
before the compiled model (startrack._core.camera.optics) became the implementation: kept as the
reference tests/camera/test_core_camera.py holds it to."""

from __future__ import annotations

import math

import numpy as np

NEWTON_ITERATIONS = 12


def _factor(d, r2):
    return 1.0 + r2 * (d.k1 + r2 * (d.k2 + r2 * d.k3))


def reference_distort(d, u, v):
    s = _factor(d, u * u + v * v)
    return u * s, v * s


def reference_undistort(d, ud, vd):
    ud = np.asarray(ud, dtype=np.float64)
    vd = np.asarray(vd, dtype=np.float64)
    rd = np.hypot(ud, vd)
    r_cap = math.sqrt(d.max_r2) if math.isfinite(d.max_r2) else math.inf
    r = np.minimum(rd, r_cap)
    for _ in range(NEWTON_ITERATIONS):
        r2 = r * r
        slope = 1.0 + r2 * (3.0 * d.k1 + r2 * (5.0 * d.k2 + r2 * 7.0 * d.k3))
        with np.errstate(divide="ignore", invalid="ignore"):
            step = (r * _factor(d, r2) - rd) / slope
        r = np.clip(r - step, 0.0, r_cap)
        if not np.any(np.abs(step) > 1e-15):
            break
    scale = np.divide(r, rd, out=np.ones_like(rd), where=rd > 0)
    return ud * scale, vd * scale


def reference_pixel_to_vector(camera, x, y):
    u, v = (np.asarray(x) - camera.cx) / camera.f_px, (np.asarray(y) - camera.cy) / camera.f_px
    if camera.distortion is not None:
        u, v = reference_undistort(camera.distortion, u, v)
    vec = np.stack([u, v, np.ones_like(u)], axis=-1)
    return vec / np.linalg.norm(vec, axis=-1, keepdims=True)


def reference_vector_to_pixel(camera, v):
    z = v[..., 2]
    front = z > 1e-12
    zs = np.where(front, z, 1.0)
    u, w = v[..., 0] / zs, v[..., 1] / zs
    if camera.distortion is not None:
        front = front & (u * u + w * w < camera.distortion.max_r2)
        u, w = reference_distort(camera.distortion, u, w)
    return camera.cx + camera.f_px * u, camera.cy + camera.f_px * w, front


def reference_half_diagonal_deg(camera):
    """The angle to the farthest corner as Camera.half_diagonal_deg computed it: a
    pinhole's in scalars, a lens's in numpy over the four corners."""
    if camera.distortion is None:
        r = max(math.hypot(x - camera.cx, y - camera.cy)
                for x in (0.0, camera.width - 1.0) for y in (0.0, camera.height - 1.0))
        return math.degrees(math.atan2(r, camera.f_px))
    corners_x = np.array([0.0, camera.width - 1.0, 0.0, camera.width - 1.0])
    corners_y = np.array([0.0, 0.0, camera.height - 1.0, camera.height - 1.0])
    v = reference_pixel_to_vector(camera, corners_x, corners_y)
    return float(np.degrees(np.arccos(np.clip(v[:, 2], -1, 1))).max())
