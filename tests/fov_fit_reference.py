"""The camera fit in numpy, as startrack.solver._fov_fit computed it before its iterations were
compiled (startrack.fov_fit_kernels): kept as the reference that tests/test_fov_fit.py
holds the compiled fit to."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from startrack.attitude import wahba_matrices
from startrack.camera._distortion import RadialDistortion
from startrack.camera._model import Camera
from startrack.solver._fov_fit import LENS_MAX_K1, LENS_MIN_R2, LENS_MIN_STARS


def reference_fit_camera(camera: Camera, x: np.ndarray, y: np.ndarray, cat_vectors: np.ndarray,
               iterations: int = 12, lens: bool = True) -> Camera:
    """``camera`` with the focal length that, with its best attitude, fits the pixels
    ``x``, ``y`` to the catalog directions: alternate Wahba's problem and the linear least
    squares of ``pixel - centre = f * D(tangent-plane position)`` (D the lens model).
    With ``lens``, a pinhole ``camera`` and at least ``LENS_MIN_STARS`` stars reaching
    ``LENS_MIN_R2``, the radial ``k1`` too (``f k1`` is linear as well): a lens nobody
    described still has its wide-field stars fitted."""
    f, k1, cam = camera.f_px, 0.0, camera
    d = np.stack([np.asarray(x, float) - camera.cx, np.asarray(y, float) - camera.cy], 1)
    with_k1 = lens and camera.distortion is None and len(d) >= LENS_MIN_STARS
    for _ in range(iterations):
        c = cat_vectors @ wahba_matrices(cam.pixel_to_vector(x, y), cat_vectors)
        t = c[:, :2] / c[:, 2:3]  # rows R^T v: catalog directions in the camera frame
        if camera.distortion is not None:  # the lens acts on the normalised plane: d = f D(t)
            t = np.stack(camera.distortion.distort(t[:, 0], t[:, 1]), 1)
        r2 = np.sum(t * t, axis=1, keepdims=True)
        if with_k1 and r2.max() >= LENS_MIN_R2:
            (f_new, g), *_ = np.linalg.lstsq(np.stack([t.ravel(), (t * r2).ravel()], 1),
                                             d.ravel(), rcond=None)
            k1_new = float(np.clip(g / f_new, -LENS_MAX_K1, LENS_MAX_K1)) if f_new > 0 else 0.0
        elif float(np.sum(t * t)) > 0:
            f_new, k1_new = float(np.sum(d * t) / np.sum(t * t)), 0.0
        else:
            break
        done = abs(f_new - f) <= 1e-10 * abs(f) and abs(k1_new - k1) <= 1e-12
        f, k1 = float(f_new), k1_new
        if not (f > 0 and math.isfinite(f)):
            return dataclasses.replace(camera, f_px=f)
        cam = dataclasses.replace(camera, f_px=f)
        if k1:
            cam = cam.with_distortion(RadialDistortion(k1=k1))
        if done:
            break
    return cam
