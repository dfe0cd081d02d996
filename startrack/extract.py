"""Centroid extraction: a grey frame in, the stars' sub-pixel positions out (OpenCV).

Pipeline: local sky background removed (block medians, interpolated; estimated twice, the
second time without the sources the first one revealed); noise from the median absolute
deviation; detection on a lightly smoothed copy at ``k_sigma`` noise sigmas;
8-connected components; intensity-weighted centroids of the unsmoothed background-removed
pixels; hot pixels and oversized blobs rejected; saturated spots flagged. Pixel convention
(interfaces.md): (0, 0) is the centre of the top-left pixel, x = column, y = row.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from startrack.centroids import Centroids

_MAD_TO_SIGMA = 1.4826
_MASK_SIGMA = 3.0  # pixels above this (dilated) are left out of the final sky model


@dataclass(frozen=True)
class CentroidConfig:
    """Settings of ``extract_centroids``; the defaults suit 8- and 16-bit star frames.

    k_sigma: detection threshold, in noise sigmas of the smoothed background-free image.
    background_size: px, side of the tiles whose medians model the sky background; larger
        than a star, smaller than the scale of vignetting or sky glow.
    min_area, max_area: px, accepted size of a detected spot (detection-mask pixels).
    hot_pixel_fraction: a spot whose brightest pixel holds more than this fraction of the
        flux in the 3x3 box around it, or whose 8 neighbours hold no significant flux, is a
        hot pixel (or cosmic ray), not a star, whose image always spreads over neighbours.
    saturation: pixel value at which a spot is flagged saturated; None = the integer
        dtype's maximum (no flag for float images).
    smooth: pre-smooth with a 3x3 Gaussian for detection only (centroids use raw pixels).
    max_stars: keep at most this many, brightest first (None = all).
    """

    k_sigma: float = 5.0
    background_size: int = 31
    min_area: int = 2
    max_area: int = 400
    hot_pixel_fraction: float = 0.9
    saturation: float | None = None
    smooth: bool = True
    max_stars: int | None = None

    def __post_init__(self) -> None:
        if not self.k_sigma > 0:
            raise ValueError(f"k_sigma must be > 0, got {self.k_sigma}")
        if self.background_size < 3:
            raise ValueError(f"background_size must be >= 3 px, got {self.background_size}")
        if not 1 <= self.min_area <= self.max_area:
            raise ValueError(f"need 1 <= min_area <= max_area, got {self.min_area}, "
                             f"{self.max_area}")
        if not 0 < self.hot_pixel_fraction <= 1:
            raise ValueError(f"hot_pixel_fraction must be in (0, 1], got "
                             f"{self.hot_pixel_fraction}")


def extract_centroids(image: np.ndarray, config: CentroidConfig | None = None) -> Centroids:
    """Find the stars in a 2-D grey frame: centroids sorted brightest first."""
    import cv2

    config = config or CentroidConfig()
    image = np.asarray(image)
    if image.ndim != 2 or image.size == 0:
        raise ValueError(f"extract_centroids needs a non-empty 2-D image, got {image.shape}")
    sat_level = _saturation_level(image.dtype, config.saturation)
    frame = image.astype(np.float32)
    finite = np.isfinite(frame)
    if not finite.all():  # dead pixels: neutral for the sky model, never a detection
        frame[~finite] = np.median(frame[finite]) if finite.any() else 0.0

    # Twice: the second sky model ignores what the first showed to be sources, so bright
    # stars and glows do not leak into it (nor, extrapolated, to the image border).
    size = config.background_size
    detect, sigma_detect = _detection_image(frame - estimate_background(frame, size),
                                            config.smooth, image.dtype)
    sources = cv2.dilate((detect > _MASK_SIGMA * sigma_detect).astype(np.uint8),
                         cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (5, 5)))
    background = estimate_background(frame, size, sources.view(bool))
    residual = frame - background
    if not finite.all():
        residual[~finite] = 0.0
    sigma = _robust_sigma(residual, image.dtype)
    detect, sigma_detect = _detection_image(residual, config.smooth, image.dtype)
    mask = (detect > config.k_sigma * sigma_detect).astype(np.uint8)
    n_labels, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
    if n_labels <= 1:
        return _empty()

    idx = np.flatnonzero(labels)  # pixels of all components, label 0 is the background
    lab = labels.ravel()[idx]
    val = residual.ravel()[idx].astype(np.float64)
    rows, cols = np.divmod(idx, image.shape[1])
    w = np.clip(val, 0.0, None)  # negative noise pixels would pull centroids off the star
    sum_w = np.bincount(lab, weights=w, minlength=n_labels)
    safe = np.where(sum_w > 0, sum_w, 1.0)
    x = np.bincount(lab, weights=w * cols, minlength=n_labels) / safe
    y = np.bincount(lab, weights=w * rows, minlength=n_labels) / safe
    flux = np.bincount(lab, weights=val, minlength=n_labels)
    area = stats[:, cv2.CC_STAT_AREA].astype(np.int64)
    saturated = np.zeros(n_labels, bool)
    if sat_level is not None:
        hit = image.ravel()[idx] >= sat_level
        saturated = np.bincount(lab[hit], minlength=n_labels) > 0

    # Peak pixel of each component: last of its pixels when sorted by (label, value).
    order = np.lexsort((val, lab))
    last = order[np.r_[np.flatnonzero(np.diff(lab[order])), len(order) - 1]]
    peak = np.zeros(n_labels)
    box = np.zeros(n_labels)
    peak[lab[last]] = val[last]
    box3 = cv2.boxFilter(residual, -1, (3, 3), normalize=False,
                         borderType=cv2.BORDER_REFLECT)
    box[lab[last]] = box3.ravel()[idx[last]]
    neighbours = box - peak
    # A star's image spreads onto its neighbours; a hot pixel's does not (beyond noise).
    hot = (peak > config.hot_pixel_fraction * box) | (neighbours < 2.0 * np.sqrt(8.0) * sigma)

    keep = (area >= config.min_area) & (area <= config.max_area) & ~hot & (sum_w > 0) \
        & (flux > 0)
    keep[0] = False
    out = Centroids(x[keep], y[keep], flux[keep], saturated[keep], area[keep])
    return out if config.max_stars is None else out.brightest(config.max_stars)


def estimate_background(frame: np.ndarray, tile: int,
                        ignore: np.ndarray | None = None) -> np.ndarray:
    """Smooth sky background: medians of ~tile x tile blocks, interpolated bilinearly.

    Pixels where ``ignore`` is true (known sources) are left out of the medians. Two
    passes: a block median across a steep gradient is noisy (the gradient spreads the
    block's values), so the second pass takes the medians of what the first left over.
    """
    background = _block_background(frame, tile, ignore, average=True)
    return background + _block_background(frame - background, tile, ignore, average=False)


def _block_background(frame: np.ndarray, tile: int, ignore: np.ndarray | None,
                      average: bool) -> np.ndarray:
    """One pass of ``estimate_background``.

    Blocks spoiled by a bright star are replaced from their neighbours; with ``average``
    the block grid is then smoothed by a 3x3 mean (planes pass unchanged). The interpolation
    extrapolates linearly to the image border, so a linear gradient passes unchanged.
    """
    h, w = frame.shape
    n_r, n_c = max(1, h // tile), max(1, w // tile)
    t_r, t_c = h // n_r, w // n_c
    o_r, o_c = (h - n_r * t_r) // 2, (w - n_c * t_c) // 2
    # Every other pixel of each block is plenty for a median (~240 of a 31 x 31 block)
    # and halves the work in each direction.
    step = 2 if min(t_r, t_c) >= 8 else 1
    blocks = frame[o_r:o_r + n_r * t_r, o_c:o_c + n_c * t_c]
    blocks = blocks.reshape(n_r, t_r, n_c, t_c)[:, ::step, :, ::step]
    if ignore is not None and ignore.any():
        # Ignored pixels become -inf and +inf in equal numbers (checkerboard): the median
        # of what is left is then the median of the kept pixels, at np.median's speed.
        skip = ignore[o_r:o_r + n_r * t_r, o_c:o_c + n_c * t_c]
        skip = skip.reshape(n_r, t_r, n_c, t_c)[:, ::step, :, ::step]
        sign = np.where((np.arange(skip.shape[1])[:, None, None] + np.arange(skip.shape[3]))
                        & 1, np.inf, -np.inf).astype(np.float32)[None]
        blocks = np.where(skip, sign, blocks)
    blocks = blocks.transpose(0, 2, 1, 3).reshape(n_r, n_c, -1)
    with np.errstate(invalid="ignore"):  # a block that is all source: (-inf + inf) / 2
        grid = np.median(blocks, axis=-1)
    grid[~np.isfinite(grid)] = np.nan
    if n_r >= 3 and n_c >= 3:
        grid = _despike(grid)
        if average and not np.isnan(grid).any():
            padded = np.pad(grid, 1, mode="reflect", reflect_type="odd")
            grid = np.lib.stride_tricks.sliding_window_view(padded, (3, 3)).mean(axis=(2, 3))
    if np.isnan(grid).any():
        grid[np.isnan(grid)] = np.nanmedian(grid) if not np.isnan(grid).all() \
            else float(np.median(frame))
    # The sampled pixels of a block are centred (step - 1) / 2 before its full centre
    # when its size is even; the interpolation uses where the samples really are.
    r0, fr = _interp_weights(h, n_r, t_r, o_r + step * ((t_r - 1) // step) / 2)
    c0, fc = _interp_weights(w, n_c, t_c, o_c + step * ((t_c - 1) // step) / 2)
    r1, c1 = np.minimum(r0 + 1, n_r - 1), np.minimum(c0 + 1, n_c - 1)
    # Separable and gathered (two tiles per pixel), not a dense matrix product.
    by_rows = grid[r0] * (1.0 - fr)[:, None] + grid[r1] * fr[:, None]  # (h, n_c)
    by_rows = by_rows.astype(np.float32)
    return by_rows[:, c0] * (1.0 - fc) + by_rows[:, c1] * fc


def _despike(grid: np.ndarray) -> np.ndarray:
    """Replace blocks that stand out from their 3x3 neighbourhood (or are NaN) by its median.

    Only outliers are replaced: a median filter over the whole grid would also erase the
    block-to-block corrections that the second background pass exists to make.
    """
    padded = np.pad(grid, 1, mode="reflect", reflect_type="odd")  # keeps planes planar
    windows = np.lib.stride_tricks.sliding_window_view(padded, (3, 3))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN windows stay NaN
        local = np.nanmedian(windows.reshape(*grid.shape, 9), axis=-1)
    deviation = np.abs(grid - local)
    if np.isnan(deviation).all():
        return local
    spread = _MAD_TO_SIGMA * np.nanmedian(deviation)
    bad = np.isnan(grid) | (deviation > 3.0 * spread)
    return np.where(bad, local, grid)


def _interp_weights(n_px: int, n_tiles: int, pitch: int,
                    first: float) -> tuple[np.ndarray, np.ndarray]:
    """Per pixel: the lower of two tiles and the weight of the upper one (float32).

    Tile i is centred at pixel ``first + i * pitch``; beyond the outer centres the weight
    leaves [0, 1], which extrapolates linearly.
    """
    if n_tiles == 1:
        return np.zeros(n_px, np.intp), np.zeros(n_px, np.float32)
    t = (np.arange(n_px) - first) / pitch
    i0 = np.clip(np.floor(t).astype(np.intp), 0, n_tiles - 2)
    return i0, (t - i0).astype(np.float32)


def _detection_image(residual: np.ndarray, smooth: bool,
                     dtype: np.dtype) -> tuple[np.ndarray, float]:
    """The image thresholded for detection and its own noise sigma."""
    import cv2

    detect = cv2.GaussianBlur(residual, (3, 3), 0) if smooth else residual
    return detect, _robust_sigma(detect, dtype)


def _robust_sigma(residual: np.ndarray, dtype: np.dtype) -> float:
    """Noise sigma from the median absolute deviation (stars barely move it)."""
    step = max(1, int(np.sqrt(residual.size / 100_000)))  # ~1e5 pixels: plenty for a MAD
    sample = residual[::step, ::step]
    med = np.median(sample)
    sigma = _MAD_TO_SIGMA * float(np.median(np.abs(sample - med)))
    if sigma > 0:
        return sigma
    sigma = float(np.std(sample))  # a nearly flat or heavily quantised frame
    if sigma > 0:
        return sigma
    return 0.5 if np.issubdtype(dtype, np.integer) else max(float(np.abs(sample).max()), 1.0) * 1e-6


def _saturation_level(dtype: np.dtype, level: float | None) -> float | None:
    if level is not None:
        return level
    if np.issubdtype(dtype, np.integer):
        return float(np.iinfo(dtype).max)
    return None


def _empty() -> Centroids:
    return Centroids(np.zeros(0), np.zeros(0), np.zeros(0))
