"""Camera calibration from solved frames: focal length, principal point and radial distortion.

:func:`calibrate` solves every frame, then fits one camera (focal length, principal point,
Brown-Conrady k1..k3) and one attitude per frame by least squares over all matched stars
(``scipy.optimize.least_squares``), rejecting outliers and re-matching the catalog with the
improved camera until the set of matched stars stops changing.

The nominal camera may be several percent off (a lens datasheet): when no frame solves at
the nominal focal length, a coarse sweep of the field of view (``SWEEP_STEPS``, with the
match tolerance widened to ``SWEEP_SIGMA_PX``) finds one that does; that frame's fit of the
focal length then seeds the solution of the others. This keeps calibration independent of
any FOV tolerance inside the matchers.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from startrack.camera import Camera, RadialDistortion, stars_in_view
from startrack.sky import Catalog
from startrack.solver._calibrate_sigma import parameters, with_final
from startrack.solver._identifier import Identifier
from startrack.verify import VerifyConfig

# Fractional FOV offsets tried, nearest first: +-2% steps out to +-10%.
SWEEP_STEPS = (0.0, -0.02, 0.02, -0.04, 0.04, -0.06, 0.06, -0.08, 0.08, -0.10, 0.10)
SWEEP_SIGMA_PX = 2.0  # measured: the real 11.4 deg frames solve 1.6-1.9% off at 2 px
SWEEP_FRAMES = 2  # frames tried at each swept FOV (a failed attempt is the slow part)
SWEEP_MAX_HYPOTHESES = 100
MAX_ROUNDS = 8  # fit + re-match rounds
REJECT_MEDIANS = 3.0  # a star whose residual exceeds this many median residuals is cut
MIN_REJECT_PX = 0.5
MAX_MATCH_PX = 10.0


@dataclass(frozen=True)
class FrameStars:
    """One solved frame: its centroids and the catalog rows matched to some of them."""

    name: str
    x: np.ndarray
    y: np.ndarray
    rotation: Rotation
    obs_index: np.ndarray
    cat_index: np.ndarray


@dataclass(frozen=True)
class Calibration:
    """The fitted camera and how well it fits: RMS in pixels per star (2-D) over the final
    inliers, with the nominal camera (attitudes refitted) and with the fitted one;
    ``parameters``: each camera parameter's value, 1-sigma and whether the data moved it
    (:mod:`startrack.solver._calibrate_sigma`)."""

    camera: Camera
    nominal: Camera
    rms_before_px: float
    rms_after_px: float
    n_stars: int
    n_rejected: int
    solved: tuple[str, ...]
    unsolved: tuple[str, ...]
    frames: tuple[FrameStars, ...]
    parameters: tuple = ()


def calibrate(frames, nominal: Camera, catalog: Catalog, *, method: str = "pyramid",
              terms: int = 1, fit_center: bool = True) -> Calibration | None:
    """Fit a camera to ``frames`` (:class:`startrack.solver._pipeline.FrameInput`) seen through a
    camera near ``nominal``. ``terms``: radial coefficients fitted (0-3; the others keep
    ``nominal``'s values). None when no frame solves."""
    solved = _solve_all(frames, nominal, catalog, method)
    if not solved:
        return None
    _, stars, inliers = _fit_loop(solved, nominal, catalog, terms, fit_center)
    camera, parameters = _settle(stars, nominal, catalog, terms, fit_center, inliers)
    before = _fit(stars, nominal, catalog, terms=0, fit_camera=False, keep=inliers)
    after = _fit(stars, camera, catalog, terms=0, fit_camera=False, keep=inliers)
    names = {s.name for s in stars}
    return Calibration(camera, nominal, before.rms, after.rms, int(inliers.sum()),
                       int((~inliers).sum()), tuple(s.name for s in stars),
                       tuple(f.name for f in frames if f.name not in names), tuple(stars),
                       parameters)


def _settle(stars, nominal: Camera, catalog: Catalog, terms: int, fit_center: bool,
            inliers: np.ndarray):
    """The camera fitted from ``nominal`` over the inliers, the parameters the data do not
    move held at nominal (startrack.solver._calibrate_sigma), and the parameters' report."""
    full = _fit(stars, nominal, catalog, terms, fit_center=fit_center, keep=inliers)
    report, hold = parameters(full, nominal)
    if not hold.any():
        return full.camera, report
    held = _fit(stars, nominal, catalog, terms, fit_center=fit_center, keep=inliers,
                hold=hold)
    return held.camera, with_final(report, held.camera)


def _solve_all(frames, nominal: Camera, catalog: Catalog, method: str) -> list[FrameStars]:
    """Every frame that solves, after finding a focal length at which one does."""
    found = _sweep(frames, nominal, catalog, method)
    if found is None:
        return []
    seed, swept = found
    camera = _fit_loop([seed], swept, catalog, 0, False, rounds=3)[0]
    ident = Identifier(camera, catalog, method, sigma_px=SWEEP_SIGMA_PX)
    out = []
    for frame in frames:
        stars = seed if frame.name == seed.name else _stars(frame, ident)
        if stars is not None:
            out.append(stars)
    return out


def _sweep(frames, nominal: Camera, catalog: Catalog,
           method: str) -> tuple[FrameStars, Camera] | None:
    """The first frame that solves and the camera it solved with, trying focal lengths
    nearest the nominal first."""
    config = VerifyConfig(max_hypotheses=SWEEP_MAX_HYPOTHESES)
    # Every swept FOV builds a database: not worth it for frames with too few stars.
    frames = [f for f in frames if len(f.centroids.x) >= 3][:SWEEP_FRAMES]
    if not frames:
        return None
    for step in SWEEP_STEPS:
        camera = dataclasses.replace(nominal, f_px=nominal.f_px / (1.0 + step))
        ident = Identifier(camera, catalog, method, sigma_px=SWEEP_SIGMA_PX,
                           verify_config=config)
        for frame in frames:
            stars = _stars(frame, ident)
            if stars is not None:
                return stars, camera
    return None


def _stars(frame, ident) -> FrameStars | None:
    solution = ident.identify(ident.observation(frame.centroids))
    if not solution.solved:
        return None
    c = frame.centroids
    return FrameStars(frame.name, np.asarray(c.x, float), np.asarray(c.y, float),
                      solution.rotation, solution.obs_index, solution.cat_index)


def _fit_loop(stars: list[FrameStars], camera: Camera, catalog: Catalog, terms: int,
              fit_center: bool, rounds: int = MAX_ROUNDS):
    """Fit, re-match with the fitted camera, repeat until the matches stop changing.
    Returns the camera, the frames' final matches and the inlier mask over them."""
    for _ in range(rounds):
        fit = _fit(stars, camera, catalog, terms, fit_center=fit_center)
        camera = fit.camera
        radius = float(np.clip(4.0 * fit.rms, 1.0, MAX_MATCH_PX))
        new = [_rematch(s, r, camera, catalog, radius)
               for s, r in zip(stars, fit.rotations, strict=True)]
        if all(np.array_equal(a.obs_index, b.obs_index)
               and np.array_equal(a.cat_index, b.cat_index)
               for a, b in zip(new, stars, strict=True)):
            return camera, new, fit.keep
        stars = new
    fit = _fit(stars, camera, catalog, terms, fit_center=fit_center)
    return fit.camera, [dataclasses.replace(s, rotation=r)
                        for s, r in zip(stars, fit.rotations, strict=True)], fit.keep


def _rematch(stars: FrameStars, rotation: Rotation, camera: Camera, catalog: Catalog,
             radius: float) -> FrameStars:
    """Pair each catalog star in view with the nearest centroid within ``radius`` px, each
    centroid and each catalog star at most once (nearest pairs first)."""
    rows, px, py = stars_in_view(catalog, camera, rotation, margin_px=-radius)
    if len(rows) == 0 or len(stars.x) == 0:
        return dataclasses.replace(stars, rotation=rotation, obs_index=np.zeros(0, np.int64),
                                   cat_index=np.zeros(0, np.int64))
    dist, nearest = cKDTree(np.column_stack([stars.x, stars.y])).query(
        np.column_stack([px, py]), distance_upper_bound=radius)
    hit = np.flatnonzero(np.isfinite(dist))
    order = hit[np.argsort(dist[hit], kind="stable")]
    _, first = np.unique(nearest[order], return_index=True)
    chosen = order[np.sort(first)]
    obs_index = nearest[chosen].astype(np.int64)
    by_obs = np.argsort(obs_index)
    return dataclasses.replace(stars, rotation=rotation, obs_index=obs_index[by_obs],
                               cat_index=rows[chosen][by_obs].astype(np.int64))


@dataclass(frozen=True)
class _Fit:
    camera: Camera
    rotations: list[Rotation]
    keep: np.ndarray  # inlier mask over the stacked matches
    rms: float
    #: which of :data:`CAMERA_PARAMETERS` were fitted, and their covariance (log focal
    #: length ratio, pixels, k)
    free: np.ndarray | None = None
    cov: np.ndarray | None = None


#: the camera parameters a fit may free, in the model's order
CAMERA_PARAMETERS = ("f", "cx", "cy", "k1", "k2", "k3")


def _fit(stars: list[FrameStars], camera: Camera, catalog: Catalog, terms: int, *,
         fit_center: bool = True, fit_camera: bool = True,
         keep: np.ndarray | None = None, hold: np.ndarray | None = None) -> _Fit:
    """Least squares over every matched star; outliers cut unless ``keep`` is given;
    ``hold`` (over :data:`CAMERA_PARAMETERS`) keeps parameters at ``camera``'s values."""
    frame = np.concatenate([np.full(len(s.obs_index), i) for i, s in enumerate(stars)])
    xo = np.concatenate([s.x[s.obs_index] for s in stars])
    yo = np.concatenate([s.y[s.obs_index] for s in stars])
    # Catalog stars in each frame's camera frame at its starting attitude.
    w = np.concatenate([s.rotation.inv().apply(catalog.vectors[s.cat_index]).reshape(-1, 3)
                        for s in stars])
    free = np.array([fit_camera, fit_center and fit_camera, fit_center and fit_camera,
                     *(fit_camera and terms > i for i in range(3))])
    model = _Model(camera, free & (True if hold is None else ~hold), len(stars))
    fixed_keep = keep is not None
    keep = np.ones(len(xo), bool) if keep is None else keep.copy()
    p = model.start()
    for _ in range(6):
        def residuals(q, sel=keep):
            x, y = model.project(q, w[sel], frame[sel])
            return np.concatenate([x - xo[sel], y - yo[sel]])

        fitted = least_squares(residuals, p, x_scale="jac", method="trf")
        p = fitted.x
        x, y = model.project(p, w, frame)
        norm = np.hypot(x - xo, y - yo)
        if fixed_keep:
            break
        limit = max(REJECT_MEDIANS * float(np.median(norm[keep])), MIN_REJECT_PX)
        new_keep = norm <= limit
        if np.array_equal(new_keep, keep) or new_keep.sum() < 3 + 3 * len(stars):
            break
        keep = new_keep
    rms = float(np.sqrt(np.mean(norm[keep] ** 2))) if keep.any() else float("nan")
    rotations = [s.rotation * Rotation.from_rotvec(model.rotvec(p, i))
                 for i, s in enumerate(stars)]
    cov = _covariance(fitted, model.n_cam) if model.n_cam else None
    return _Fit(model.camera(p), rotations, keep, rms, model.free, cov)


def _covariance(fitted, n_cam: int) -> np.ndarray:
    """The free camera values' covariance: the fit's Jacobian, the noise per coordinate
    estimated from its residuals."""
    jac, res = np.asarray(fitted.jac), np.asarray(fitted.fun)
    noise2 = float(res @ res) / max(len(res) - jac.shape[1], 1)
    return noise2 * np.linalg.pinv(jac.T @ jac)[:n_cam, :n_cam]


class _Model:
    """The parameter vector: the free ones of the camera's values (log focal-length ratio,
    principal point offset, radial coefficients; ``free`` over
    :data:`CAMERA_PARAMETERS`), then a small rotation vector per frame."""

    def __init__(self, camera: Camera, free: np.ndarray, n_frames: int) -> None:
        self.base = camera
        d = camera.distortion or RadialDistortion()
        self.values = np.array([0.0, 0.0, 0.0, d.k1, d.k2, d.k3])
        self.free = np.asarray(free, dtype=bool)
        self.n_cam = int(self.free.sum())
        self.n_frames = n_frames

    def start(self) -> np.ndarray:
        p = np.zeros(self.n_cam + 3 * self.n_frames)
        p[:self.n_cam] = self.values[self.free]
        return p

    def _camera_values(self, p: np.ndarray):
        v = self.values.copy()
        v[self.free] = p[:self.n_cam]
        return self.base.f_px * np.exp(v[0]), self.base.cx + v[1], self.base.cy + v[2], v[3:]

    def rotvec(self, p: np.ndarray, i: int) -> np.ndarray:
        return p[self.n_cam + 3 * i:self.n_cam + 3 * i + 3]

    def project(self, p: np.ndarray, w: np.ndarray, frame: np.ndarray):
        f, cx, cy, k = self._camera_values(p)
        turns = p[self.n_cam:].reshape(-1, 3)[frame]
        v = Rotation.from_rotvec(-turns).apply(w) if len(w) else w  # (R exp(t))^T = exp(-t) R^T
        u, t = v[:, 0] / v[:, 2], v[:, 1] / v[:, 2]
        r2 = u * u + t * t
        s = 1.0 + r2 * (k[0] + r2 * (k[1] + r2 * k[2]))
        return cx + f * u * s, cy + f * t * s

    def camera(self, p: np.ndarray) -> Camera:
        f, cx, cy, k = self._camera_values(p)
        base = dataclasses.replace(self.base, f_px=float(f), cx=float(cx), cy=float(cy),
                                   distortion=None)
        return base.with_distortion(RadialDistortion(*(float(c) for c in k)))
