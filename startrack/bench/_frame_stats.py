"""What a real and a simulated frame are compared by (docs/simulation.md, "Checked against
real frames"): catalog stars detected per magnitude bin, the background's level and
noise, the PSF's FWHM and the number of saturated stars.

Both frames go through the same measurement: centroids from the pipeline's extractor,
matched to the catalog stars projected at the frame's attitude; the background level is
the median pixel, its noise the robust spread of neighbouring pixels' differences (so a
vignetting gradient does not count as noise); the FWHM is the median over bright,
unsaturated, isolated stars of a pixel-integrated Gaussian fitted to each.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares
from scipy.spatial import cKDTree
from scipy.special import erf

from startrack.camera import Camera, stars_in_view
from startrack.sky import Catalog

MATCH_RADIUS_PX = 3.0
_FIT_HALF = 5  # the fitted window is 11 x 11 pixels
_SIGMA_TO_FWHM = 2.0 * math.sqrt(2.0 * math.log(2.0))


@dataclass(frozen=True)
class FrameStats:
    """The measured numbers of one frame; ``detected[k]``/``in_view[k]`` count catalog
    stars with magnitude in ``[mag_edges[k], mag_edges[k + 1])``."""

    mag_edges: tuple[float, ...]
    detected: tuple[int, ...]
    in_view: tuple[int, ...]
    background_mean: float
    background_noise: float
    fwhm_px: float
    saturated_stars: int

    def bins(self) -> list[str]:
        e = self.mag_edges
        return [f"{e[k]:g}-{e[k + 1]:g}" for k in range(len(e) - 1)]


def _noise(image: np.ndarray) -> float:
    """Robust pixel noise: the MAD of horizontal neighbour differences over sqrt(2)."""
    diff = np.diff(image.astype(np.float64), axis=1).ravel()
    mad = np.median(np.abs(diff - np.median(diff)))
    return float(1.4826 * mad / math.sqrt(2.0))


def _gauss_model(params, rows, cols):
    amp, x0, y0, sigma, bg = params
    s = math.sqrt(2.0) * max(sigma, 0.05)
    fx = 0.5 * (erf((cols + 0.5 - x0) / s) - erf((cols - 0.5 - x0) / s))
    fy = 0.5 * (erf((rows + 0.5 - y0) / s) - erf((rows - 0.5 - y0) / s))
    return amp * fx * fy + bg


def fit_fwhm(image: np.ndarray, x: float, y: float) -> float | None:
    """FWHM (px) of a pixel-integrated round Gaussian fitted about (x, y); None when the
    window leaves the image or the fit fails."""
    r0, c0 = int(round(y)) - _FIT_HALF, int(round(x)) - _FIT_HALF
    size = 2 * _FIT_HALF + 1
    if r0 < 0 or c0 < 0 or r0 + size > image.shape[0] or c0 + size > image.shape[1]:
        return None
    win = image[r0:r0 + size, c0:c0 + size].astype(np.float64)
    rows, cols = np.mgrid[r0:r0 + size, c0:c0 + size]
    bg = float(np.median(np.concatenate([win[0], win[-1], win[:, 0], win[:, -1]])))
    start = [float(win.sum() - bg * win.size), x, y, 1.0, bg]
    fit = least_squares(lambda p: (_gauss_model(p, rows, cols) - win).ravel(), start,
                        bounds=([0, x - 2, y - 2, 0.2, -np.inf], [np.inf, x + 2, y + 2, 6.0,
                                                                    np.inf]))
    return float(_SIGMA_TO_FWHM * fit.x[3]) if fit.success else None


def frame_stats(image: np.ndarray, camera: Camera, rotation, catalog: Catalog,
                mag_edges: tuple[float, ...], adc_max: int | None = None,
                fwhm_stars: int = 15) -> FrameStats:
    """The :class:`FrameStats` of ``image`` seen at ``rotation`` through ``camera``."""
    from startrack.centroids import extract_centroids

    rows, px, py = stars_in_view(catalog, camera, rotation)
    mags = catalog.mag[rows]
    found = extract_centroids(image)
    edges = np.asarray(mag_edges, dtype=np.float64)
    in_view = np.histogram(mags, edges)[0]
    hit = np.zeros(len(rows), bool)
    nearest = np.full(len(found.x), -1)
    if len(rows) and len(found.x):
        dist, idx = cKDTree(np.column_stack([px, py])).query(
            np.column_stack([found.x, found.y]), distance_upper_bound=MATCH_RADIUS_PX)
        ok = np.isfinite(dist)
        hit[idx[ok]] = True
        nearest[ok] = idx[ok]
    detected = np.histogram(mags[hit], edges)[0]
    top = float(np.iinfo(image.dtype).max if adc_max is None and image.dtype.kind == "u"
                else adc_max if adc_max is not None else image.max())
    peaks = _peaks(image, found.x, found.y)
    saturated = int(np.count_nonzero((nearest >= 0) & (peaks >= top)))
    fwhm = _median_fwhm(image, found, nearest, peaks < top, fwhm_stars)
    return FrameStats(tuple(float(e) for e in edges), tuple(int(v) for v in detected),
                      tuple(int(v) for v in in_view), float(np.median(image)),
                      _noise(image), fwhm, saturated)


def _peaks(image: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The brightest pixel within a pixel of each centroid."""
    h, w = image.shape
    out = np.zeros(len(x))
    for k, (cx, cy) in enumerate(zip(np.rint(x).astype(int), np.rint(y).astype(int),
                                     strict=True)):  # a few hundred spots a frame
        win = image[max(cy - 1, 0):min(cy + 2, h), max(cx - 1, 0):min(cx + 2, w)]
        out[k] = float(win.max()) if win.size else 0.0
    return out


def _median_fwhm(image, found, nearest, unsaturated, count: int) -> float:
    """Median FWHM of the brightest matched, unsaturated stars with no other star within
    the fitted window."""
    tree = cKDTree(np.column_stack([found.x, found.y])) if len(found.x) else None
    widths = []
    for k in np.argsort(-found.flux):  # brightest first; stops after ``count`` fits
        if nearest[k] < 0 or not unsaturated[k]:
            continue
        if len(tree.query_ball_point([found.x[k], found.y[k]], 2.0 * _FIT_HALF)) > 1:
            continue
        width = fit_fwhm(image, found.x[k], found.y[k])
        if width is not None:
            widths.append(width)
        if len(widths) >= count:
            break
    return float(np.median(widths)) if widths else float("nan")

__all__ = ["FrameStats", "MATCH_RADIUS_PX", "fit_fwhm", "frame_stats"]
