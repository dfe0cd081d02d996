"""The camera fit as scipy's least squares states it: the reference that
tests/solver/test_fov_fit.py
holds the compiled fit (startrack._core.camera.fit) to. The same residuals (pixel offset
minus the focal length times the lens applied to the catalog direction on the tangent
plane), the same start (Wahba's attitude from the pixels at the given focal length),
minimised by ``scipy.optimize.least_squares`` over a rotation vector, the focal length
and, for an undescribed lens, k1 within its bound, kept only where it lowers the squared
residuals by more than ``LENS_K1_CHI2`` times their variance."""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from startrack.attitude import wahba_matrices
from startrack.camera import Camera
from startrack.solver._fov_fit import LENS_K1_CHI2, LENS_MAX_K1, LENS_MIN_R2, LENS_MIN_STARS


def pixel_residuals(camera: Camera, rot: np.ndarray, f: float, k1: float, x: np.ndarray,
                    y: np.ndarray, cat_vectors: np.ndarray) -> np.ndarray:
    """The (x, y) residuals, interleaved, of catalog directions ``cat_vectors`` through
    attitude ``rot`` (camera to sky), focal length ``f`` and the lens: ``camera``'s
    when it has one, else the k1-only lens ``k1``."""
    c = cat_vectors @ rot  # rows R^T v: the directions in the camera frame
    t = c[:, :2] / c[:, 2:3]
    r2 = np.sum(t * t, axis=1, keepdims=True)
    if camera.distortion is not None:
        d = camera.distortion
        scale = 1.0 + r2 * (d.k1 + r2 * (d.k2 + r2 * d.k3))
    else:
        scale = 1.0 + k1 * r2
    offsets = np.stack([np.asarray(x, float) - camera.cx, np.asarray(y, float) - camera.cy], 1)
    return (offsets - f * scale * t).ravel()


def reference_fit(camera: Camera, x: np.ndarray, y: np.ndarray, cat_vectors: np.ndarray,
                  lens: bool = True) -> tuple[float, float, float]:
    """(focal length, k1, sum of squared residuals) at scipy's least-squares optimum from
    the compiled fit's start; k1 is fitted as ``fit_camera`` fits it (a pinhole, at
    least ``LENS_MIN_STARS`` stars, one reaching ``LENS_MIN_R2`` at the start)."""
    start = wahba_matrices(camera.pixel_to_vector(x, y), cat_vectors)
    c = cat_vectors @ start
    reach = float(np.max(np.sum((c[:, :2] / c[:, 2:3]) ** 2, axis=1)))
    with_k1 = (lens and camera.distortion is None and len(x) >= LENS_MIN_STARS
               and reach >= LENS_MIN_R2)

    def residuals(p: np.ndarray) -> np.ndarray:
        rot = start @ Rotation.from_rotvec(p[:3]).as_matrix()
        return pixel_residuals(camera, rot, p[3], p[4] if with_k1 else 0.0, x, y,
                               cat_vectors)

    tight = {"xtol": 1e-15, "ftol": 1e-15, "gtol": 1e-15, "max_nfev": 2000}
    plain = least_squares(lambda p: pixel_residuals(
        camera, start @ Rotation.from_rotvec(p[:3]).as_matrix(), p[3], 0.0, x, y,
        cat_vectors), np.array([0.0, 0.0, 0.0, camera.f_px]), method="lm", x_scale="jac",
        **tight)
    plain_cost = float(np.sum(plain.fun**2))
    if not with_k1:
        return float(plain.x[3]), 0.0, plain_cost
    bounds = ([-np.inf] * 4 + [-LENS_MAX_K1], [np.inf] * 4 + [LENS_MAX_K1])
    found = least_squares(residuals, np.array([0.0, 0.0, 0.0, camera.f_px, 0.0]),
                          bounds=bounds, method="trf", x_scale="jac", **tight)
    cost = float(np.sum(found.fun**2))
    # k1 stands only where it lowers the residuals by more than LENS_K1_CHI2 variances
    dof = 2 * len(x) - 5
    if dof <= 0 or (plain_cost - cost) * dof <= LENS_K1_CHI2 * cost:
        return float(plain.x[3]), 0.0, plain_cost
    return float(found.x[3]), float(found.x[4]), cost
