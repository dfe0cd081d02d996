"""Centroid extraction: a grey frame in, the stars' sub-pixel positions out (numba kernels).

Pipeline: local sky background removed (block medians, interpolated; estimated twice, the
second time without the sources the first one revealed); noise from the median absolute
deviation; detection on a lightly smoothed copy at ``k_sigma`` noise sigmas;
8-connected components; intensity-weighted centroids of the unsmoothed background-removed
pixels; hot pixels and oversized blobs rejected; saturated spots flagged. Pixel convention
(interfaces.md): (0, 0) is the centre of the top-left pixel, x = column, y = row.

The pixel work runs in ``startrack.extract_kernels``, which reads the frame in its own
dtype and evaluates the sky model on the fly: besides the frame, an extraction holds one
byte per pixel (the source mask of the first pass), whatever the frame's size.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from startrack import extract_kernels as kern
from startrack import extract_sky as sky
from startrack.centroids import Centroids

_MAD_TO_SIGMA = 1.4826
_MASK_SIGMA = 3.0  # pixels above this (dilated) are left out of the final sky model
_AREA_PER_MPX = 400  # default max_area of a 1024 x 1024 frame, scaled with the frame
_NATIVE = (np.uint8, np.uint16, np.int16, np.float32, np.float64)  # kernels take these


@dataclass(frozen=True)
class CentroidConfig:
    """Settings of ``extract_centroids``; the defaults suit 8- and 16-bit star frames.

    k_sigma: detection threshold, in noise sigmas of the smoothed background-free image.
    background_size: px, side of the tiles whose medians model the sky background; larger
        than a star, smaller than the scale of vignetting or sky glow.
    min_area, max_area: px, accepted size of a detected spot (detection-mask pixels).
        ``max_area=None`` scales with the frame: 400 px per 1024 x 1024 pixels (at least
        400), since the same optics on a larger detector spread a star over more pixels.
    max_saturated_area: px, size limit of a spot with a saturated pixel, whose image
        blooms with brightness (None = 4 x max_area): the brightest stars are kept.
    hot_pixel_fraction: a spot whose brightest pixel holds more than this fraction of the
        flux in the 3x3 box around it, or whose 8 neighbours hold no significant flux, is a
        hot pixel (or cosmic ray), not a star, whose image always spreads over neighbours.
    saturation: pixel value at which a spot is flagged saturated; None = the integer
        dtype's maximum (no flag for float images).
    smooth: pre-smooth with a 3x3 Gaussian for detection only (centroids use raw pixels).
    max_stars: keep at most this many, brightest first (None = all).
    fast: one sky model from every fourth pixel of each tile, without the second,
        source-masked estimate: about twice as fast, at the cost of the faintest stars
        (bright stars' wings leak into the sky model); ``FAST`` is this preset.
    """

    k_sigma: float = 5.0
    background_size: int = 31
    min_area: int = 2
    max_area: int | None = None
    max_saturated_area: int | None = None
    hot_pixel_fraction: float = 0.9
    saturation: float | None = None
    smooth: bool = True
    max_stars: int | None = None
    fast: bool = False

    def __post_init__(self) -> None:
        if not self.k_sigma > 0:
            raise ValueError(f"k_sigma must be > 0, got {self.k_sigma}")
        if self.background_size < 3:
            raise ValueError(f"background_size must be >= 3 px, got {self.background_size}")
        if not 1 <= self.min_area <= (self.max_area or self.min_area):
            raise ValueError(f"need 1 <= min_area <= max_area, got {self.min_area}, "
                             f"{self.max_area}")
        if self.max_saturated_area is not None and self.max_saturated_area < self.min_area:
            raise ValueError(f"max_saturated_area must be >= min_area, got "
                             f"{self.max_saturated_area}")
        if not 0 < self.hot_pixel_fraction <= 1:
            raise ValueError(f"hot_pixel_fraction must be in (0, 1], got "
                             f"{self.hot_pixel_fraction}")

    def area_limits(self, shape: tuple[int, int]) -> tuple[int, int]:
        """(max_area, max_saturated_area) in px for a frame of ``shape``."""
        auto = max(_AREA_PER_MPX, round(_AREA_PER_MPX * shape[0] * shape[1] / 2**20))
        max_area = self.max_area if self.max_area is not None else auto
        saturated = self.max_saturated_area if self.max_saturated_area is not None \
            else 4 * max_area
        return max_area, saturated


FAST = CentroidConfig(fast=True)


def extract_centroids(image: np.ndarray, config: CentroidConfig | None = None) -> Centroids:
    """Find the stars in a 2-D grey frame.

    Parameters
    ----------
    image : 2-D array of any real dtype (uint8, uint16 and float frames are read as they
        are; other dtypes are converted to float64). NaN and infinite pixels are dead:
        neutral for the sky model and never detected.
    config : CentroidConfig, optional

    Returns
    -------
    Centroids sorted brightest first.
    """
    import cv2

    config = config or CentroidConfig()
    image = np.asarray(image)
    if image.ndim != 2 or image.size == 0:
        raise ValueError(f"extract_centroids needs a non-empty 2-D image, got {image.shape}")
    if image.dtype.type not in _NATIVE:
        image = image.astype(np.float64)
    sat_level = _saturation_level(image.dtype, config.saturation)
    fill = _dead_pixel_fill(image)
    geometries, weights = _tile_geometry(image.shape, config.background_size)
    step = max(1, round(math.sqrt(image.size / 100_000)))  # ~1e5 pixels: plenty for a MAD

    model = _sky_model(image, fill, geometries, weights, None, False)
    if not config.fast:
        # Twice: the second sky model ignores what the first showed to be sources, so
        # bright stars and glows do not leak into it (nor, extrapolated, to the border).
        # a 3-sigma source mask needs a rougher noise estimate: a quarter of the samples
        _, det = kern.samples(image, model, 2 * step, config.smooth)
        sources = kern.detection_mask(image, model, _MASK_SIGMA * _mad_sigma(det, image.dtype),
                                      config.smooth)
        sources = cv2.dilate(sources, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (5, 5)))
        model = _sky_model(image, fill, geometries, weights, sources, True)
        del sources
    res, det = kern.samples(image, model, step, config.smooth)
    sigma, sigma_det = _mad_sigma(res, image.dtype), _mad_sigma(det, image.dtype)
    comp = kern.components(image, model, config.k_sigma * sigma_det, config.smooth,
                           np.inf if sat_level is None else sat_level)
    if len(comp) == 0:
        return _empty()

    box = kern.peak_boxes(image, model, comp[:, kern.PEAK_AT])
    peak, sum_w, flux = comp[:, kern.PEAK], comp[:, kern.SW], comp[:, kern.FLUX]
    area, saturated = comp[:, kern.AREA].astype(np.int64), comp[:, kern.SAT] > 0
    # A star's image spreads onto its neighbours; a hot pixel's does not (beyond noise).
    hot = (peak > config.hot_pixel_fraction * box) | (box - peak < 2.0 * math.sqrt(8.0) * sigma)
    max_area, max_saturated = config.area_limits(image.shape)
    keep = (area >= config.min_area) & (area <= np.where(saturated, max_saturated, max_area)) \
        & ~hot & (sum_w > 0) & (flux > 0)
    safe = np.where(sum_w > 0, sum_w, 1.0)
    out = Centroids(comp[keep, kern.SWX] / safe[keep], comp[keep, kern.SWY] / safe[keep],
                    flux[keep], saturated[keep], area[keep])
    return out if config.max_stars is None else out.brightest(config.max_stars)


def estimate_background(frame: np.ndarray, tile: int,
                        ignore: np.ndarray | None = None) -> np.ndarray:
    """Smooth sky background (float32 image): medians of ~tile x tile blocks, interpolated.

    Pixels where ``ignore`` is true (known sources) are left out of the medians. Two
    passes: a block median across a steep gradient is noisy (the gradient spreads the
    block's values), so the second pass takes the medians of what the first left over.
    """
    frame = np.asarray(frame)
    if frame.dtype.type not in _NATIVE:
        frame = frame.astype(np.float64)
    geometries, weights = _tile_geometry(frame.shape, tile)
    mask = None if ignore is None else np.ascontiguousarray(ignore, dtype=np.uint8)
    model = _sky_model(frame, _dead_pixel_fill(frame), geometries, weights, mask, True)
    return kern.background_image(model, *frame.shape)


def _sky_model(image, fill, geometries, weights, ignore, fine: bool) -> tuple:
    """The two-pass block-median sky model as a kernel tuple.

    The first pass (tile medians, smoothed) samples every fourth pixel of a tile: the
    second pass measures what it left in each tile, its errors included. The second
    pass samples every other pixel when ``fine``, every fourth otherwise.
    """
    coarse, dense = geometries
    skip = np.zeros((0, 0), np.uint8) if ignore is None else ignore
    zero = (np.zeros((coarse[0], coarse[1])),) + weights
    grid = sky.block_medians(image, fill, zero, False, skip, coarse)
    grid = sky.clean_grid(grid, True, _sample_median(image, fill))
    model = (grid,) + weights
    extra = sky.block_medians(image, fill, model, True, skip, dense if fine else coarse)
    grid = grid + sky.clean_grid(extra, False, 0.0)
    return (grid,) + weights + (kern.column_rows(grid, weights[3], weights[4], weights[5]),)


def _tile_geometry(shape: tuple[int, int], tile: int) -> tuple[tuple, tuple]:
    """Tile layouts for ``block_medians`` (every fourth and every other pixel of a tile)
    and the per-row and per-column interpolation weights."""
    h, w = shape
    n_r, n_c = max(1, h // tile), max(1, w // tile)
    t_r, t_c = h // n_r, w // n_c
    o_r, o_c = (h - n_r * t_r) // 2, (w - n_c * t_c) // 2
    # Every other pixel of each block is plenty for a median (~240 of a 31 x 31 block)
    # and halves the work in each direction.
    step = 2 if min(t_r, t_c) >= 8 else 1
    dense = (n_r, n_c, t_r, t_c, o_r, o_c, step, 0, 0)
    coarse = dense
    if min(t_r, t_c) >= 16:  # every fourth pixel, centred where the dense samples are
        coarse = (n_r, n_c, t_r, t_c, o_r, o_c, 4, ((t_r - 1) % 4) // 2, ((t_c - 1) % 4) // 2)
    # The sampled pixels of a block are centred (step - 1) / 2 before its full centre
    # when its size is even; the interpolation uses where the samples really are.
    r0, r1, fr = _interp_weights(h, n_r, t_r, o_r + step * ((t_r - 1) // step) / 2)
    c0, c1, fc = _interp_weights(w, n_c, t_c, o_c + step * ((t_c - 1) // step) / 2)
    return (coarse, dense), (r0, r1, fr, c0, c1, fc)


def _interp_weights(n_px: int, n_tiles: int, pitch: int, first: float) -> tuple:
    """Per pixel: the lower and upper of two tiles and the weight of the upper one.

    Tile i is centred at pixel ``first + i * pitch``; beyond the outer centres the weight
    leaves [0, 1], which extrapolates linearly.
    """
    if n_tiles == 1:
        zero = np.zeros(n_px, np.int64)
        return zero, zero, np.zeros(n_px)
    t = (np.arange(n_px) - first) / pitch
    i0 = np.clip(np.floor(t).astype(np.int64), 0, n_tiles - 2)
    return i0, i0 + 1, t - i0


def _mad_sigma(sample: np.ndarray, dtype: np.dtype) -> float:
    """Noise sigma from the median absolute deviation (stars barely move it)."""
    sigma = sky.mad_sigma(sample, _MAD_TO_SIGMA)
    if sigma > 0:
        return sigma
    sigma = float(np.std(sample))  # a nearly flat or heavily quantised frame
    if sigma > 0:
        return sigma
    return 0.5 if np.issubdtype(dtype, np.integer) else max(float(np.abs(sample).max()), 1.0) * 1e-6


def _dead_pixel_fill(image: np.ndarray) -> float:
    """Value that NaN and infinite pixels take in the sky model: the finite median."""
    if np.issubdtype(image.dtype, np.integer):
        return 0.0
    finite = np.isfinite(image)
    if finite.all():
        return 0.0
    return float(np.median(image[finite])) if finite.any() else 0.0


def _sample_median(image: np.ndarray, fill: float) -> float:
    step = max(1, round(math.sqrt(image.size / 10_000)))
    sample = image[::step, ::step].astype(np.float64)
    sample[~np.isfinite(sample)] = fill
    return float(np.median(sample))


def _saturation_level(dtype: np.dtype, level: float | None) -> float | None:
    if level is not None:
        return level
    if np.issubdtype(dtype, np.integer):
        return float(np.iinfo(dtype).max)
    return None


def _empty() -> Centroids:
    return Centroids(np.zeros(0), np.zeros(0), np.zeros(0))
