"""Centroid extraction: a grey frame in, the stars' sub-pixel positions out (numba kernels).

Pipeline: sky background removed (tile medians of 4 x 4 block means, interpolated; estimated
twice, the second time without the blocks that held sources); noise from the median absolute
deviation; detection at ``k_sigma`` sigmas on a lightly smoothed copy; 8-connected components;
intensity-weighted centroids of the unsmoothed pixels, background removed; hot pixels and
oversized blobs rejected; saturated spots flagged. Pixels as docs/conventions.md says.

The frame is read twice, in its own dtype: for the block means the sky model is made of
(``startrack.extract_blocks``), then row by row for detection and moments
(``startrack.extract_kernels``); besides it, an extraction holds 1/16 of it and a few rows.

Threads: the passes over the pixels run on bands of rows, on ``CentroidConfig.threads``
threads (default: numba's ``NUMBA_NUM_THREADS``, fewer when the load average says the cores
are taken, one under ~2 x 65536 px): helper threads (``startrack.extract_parallel``) run the
kernels, which release the GIL. Each band writes its own part of a result, the blobs' runs are
joined in raster order: the same centroids, bit for bit and in order, whatever the threads.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from startrack import extract_blocks as blocks
from startrack import extract_grid as tiles
from startrack import extract_kernels as kern
from startrack import extract_parallel as par
from startrack import extract_runs as runs
from startrack import extract_sky as sky
from startrack.centroids._table import Centroids

_MAD_TO_SIGMA = 1.4826
_MASK_SIGMA = 3.0  # blocks above this (grown) are left out of the final sky model
_AREA_PER_MPX = 400  # default max_area of a 1024 x 1024 frame, scaled with the frame
_NO_MASK = np.zeros((0, 0), np.uint8)
_NO_GRID = np.zeros((0, 0))
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
    fast: one sky model, without the second, source-masked estimate: somewhat faster, at
        the cost of the faintest stars near bright ones (bright stars' wings leak into
        the sky model); ``FAST`` is this preset.
    threads: threads that the passes over the pixels run on (None = numba's limit,
        ``NUMBA_NUM_THREADS``, by default the cores this process may use, or fewer when
        other processes keep them busy). The result is the same, bit for bit, whatever
        the number.
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
    threads: int | None = None

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
        if self.threads is not None and self.threads < 1:
            raise ValueError(f"threads must be >= 1, got {self.threads}")

    def area_limits(self, shape: tuple[int, int]) -> tuple[int, int]:
        """(max_area, max_saturated_area) in px for a frame of ``shape``."""
        auto = max(_AREA_PER_MPX, round(_AREA_PER_MPX * shape[0] * shape[1] / 2**20))
        max_area = self.max_area if self.max_area is not None else auto
        saturated = self.max_saturated_area if self.max_saturated_area is not None \
            else 4 * max_area
        return max_area, saturated


FAST = CentroidConfig(fast=True)


def extract_centroids(image: np.ndarray, config: CentroidConfig | None = None) -> Centroids:
    """Find the stars in a 2-D grey frame (how: the module docstring).

    Parameters
    ----------
    image : numpy.ndarray
        2-D, of any real dtype (uint8, uint16 and float as they are, others as float64);
        NaN and infinite pixels are dead: neutral for the sky model, never detected.
    config : CentroidConfig, optional
        Thresholds, sizes and threads (default ``CentroidConfig()``).

    Returns
    -------
    Centroids
        Pixel x, y (docs/conventions.md), flux, area and saturation, brightest first.

    Raises
    ------
    ValueError
        ``image`` is not a non-empty 2-D array.

    Examples
    --------
    >>> import numpy as np
    >>> from startrack.centroids import extract_centroids
    >>> yy, xx = np.mgrid[:96, :96]
    >>> image = np.random.default_rng(0).normal(100.0, 2.0, (96, 96))
    >>> image += 900.0 * np.exp(-((xx - 30.2) ** 2 + (yy - 40.7) ** 2) / 4.5)
    >>> stars = extract_centroids(image)
    >>> len(stars), round(float(stars.x[0]), 1), round(float(stars.y[0]), 1)
    (1, 30.2, 40.7)
    """
    config = config or CentroidConfig()
    image = np.asarray(image)
    if image.ndim != 2 or image.size == 0:
        raise ValueError(f"extract_centroids needs a non-empty 2-D image, got {image.shape}")
    if image.dtype.type not in _NATIVE:
        image = image.astype(np.float64)
    sat_level = _saturation_level(image.dtype, config.saturation)
    threads = par.thread_count(config.threads)
    model = _sky_model(image, config.background_size, config.fast, threads)
    step = max(1, round(math.sqrt(image.size / 25_000)))  # ~2.5e4 px: a MAD to ~1 %
    sigma, sigma_det = _noise(image, model, step, config.smooth, threads)
    comp = _components(image, model, config.k_sigma * sigma_det, config.smooth,
                       np.inf if sat_level is None else sat_level, threads)
    if len(comp) == 0:
        return _empty()

    box = kern.peak_boxes(image, model, comp[:, runs.PEAK_AT])
    # A star's image spreads onto its neighbours; a hot pixel's does not (beyond noise).
    out = Centroids(*runs.stars(comp, box, config.hot_pixel_fraction,
                                2.0 * math.sqrt(8.0) * sigma, config.min_area,
                                *config.area_limits(image.shape)))
    return out if config.max_stars is None else out.brightest(config.max_stars)


def estimate_background(frame: np.ndarray, tile: int,
                        ignore: np.ndarray | None = None) -> np.ndarray:
    """Smooth sky background (float32 image): medians of the 4 x 4 block means of
    ~tile x tile tiles, interpolated.

    Blocks holding a pixel where ``ignore`` is true (known sources) are left out of the
    medians. Two passes: a tile median across a steep gradient is noisy (the gradient
    spreads the tile's values), so the second pass takes the medians of what the first
    left over.
    """
    frame = np.asarray(frame)
    if frame.dtype.type not in _NATIVE:
        frame = frame.astype(np.float64)
    lay = blocks.layout(tuple(frame.shape), tile)
    pixel_w, block_w = blocks.weights(tuple(frame.shape), lay)
    means = blocks.block_means(frame, _dead_pixel_fill(frame), lay)
    mask = _NO_MASK
    if ignore is not None:
        mask = (blocks.block_means(np.asarray(ignore, np.uint8), 0.0, lay) > 0).astype(np.uint8)
    raw = blocks.tile_medians(means, mask, lay[7], lay[8], _NO_GRID, block_w, _NO_GRID)
    grid = _sky_grid(means, lay, block_w, mask, float(np.median(means)), raw, 1)
    model = (grid,) + pixel_w + (kern.column_rows(grid, *pixel_w[3:]),)
    return kern.background_image(model, *frame.shape)


def _sky_model(image: np.ndarray, tile: int, fast: bool, threads: int) -> tuple:
    """The sky model (``extract_kernels``'s tuple) of ``image`` from its block means."""
    lay = blocks.layout(tuple(image.shape), tile)
    pixel_w, block_w = blocks.weights(tuple(image.shape), lay)
    means = np.empty((lay[0] * lay[7], lay[1] * lay[8]), np.float32)
    raw = np.empty((lay[0], lay[1]))
    fill = _dead_pixel_fill(image)
    par.run(blocks.sky_rows, [(image, fill, lay, block_w, a, b, means, raw)
                              for a, b in _tile_bands(lay, threads, image.size)], threads)
    grid = _sky_grid(means, lay, block_w, _NO_MASK, 0.0, raw, threads)
    if not fast:
        # Twice: the second sky model ignores the blocks the first showed to hold
        # sources, so bright stars and glows do not leak into it (nor, extrapolated, to
        # the border). A block mean is already smoothed: 3 of its sigmas mark a source.
        resid = blocks.residual(means, grid, *block_w)
        sources = blocks.sources(resid, _MASK_SIGMA * _mad_sigma(resid[::2, ::2].ravel(),
                                                                 image.dtype))
        masked = _tile_medians(means, sources, lay, _NO_GRID, block_w, raw, threads)
        grid = _sky_grid(means, lay, block_w, sources, sky.median_of(grid.ravel()), masked,
                         threads)
    return (grid,) + pixel_w + (kern.column_rows(grid, *pixel_w[3:]),)


def _sky_grid(means: np.ndarray, lay: tuple, block_w: tuple, ignore: np.ndarray,
              fallback: float, raw: np.ndarray, threads: int) -> np.ndarray:
    """Tile values of the two-pass sky model from the block means and their tile medians.

    First the tile medians ``raw``, cleaned of spikes and smoothed; then the median of
    what that model leaves in each tile is added (only despiked), so the model follows
    the sky glow from tile to tile. ``ignore``: blocks left out; ``fallback``: the value
    when every block is.
    """
    grid = tiles.clean_grid(raw, True, fallback)
    extra = _tile_medians(means, ignore, lay, grid, block_w, _NO_GRID, threads)
    return grid + tiles.clean_grid(extra, False, 0.0)


def _tile_bands(lay: tuple, threads: int, pixels: int) -> list[tuple[int, int]]:
    return par.bands(lay[0], par.parts_for(threads, pixels))


def _tile_medians(means: np.ndarray, ignore: np.ndarray, lay: tuple, grid: np.ndarray,
                  block_w: tuple, known: np.ndarray, threads: int) -> np.ndarray:
    """``extract_blocks.tile_medians``, bands of tile rows on ``threads`` threads."""
    out = np.empty((lay[0], lay[1]))
    par.run(blocks.tile_rows, [(means, ignore, lay[7], lay[8], grid, block_w, known, a, b, out)
                               for a, b in _tile_bands(lay, threads, 16 * means.size)],
            threads)
    return out


def _noise(image: np.ndarray, model: tuple, step: int, smooth: bool,
           threads: int) -> tuple[float, float]:
    """Noise sigma of the residual and of the detection image, from samples on the grid
    [::step, ::step]."""
    n_rows, n_cols = -(-image.shape[0] // step), -(-image.shape[1] // step)
    res, det = np.empty(n_rows * n_cols), np.empty(n_rows * n_cols)
    parts = par.bands(n_rows, par.parts_for(threads, 9 * res.size))
    par.run(kern.samples, [(image, model, step, smooth, a, b, res, det) for a, b in parts],
            threads)
    sigmas = par.run(sky.mad_sigma, [(res, _MAD_TO_SIGMA), (det, _MAD_TO_SIGMA)], threads)
    return _mad_sigma(res, image.dtype, sigmas[0]), _mad_sigma(det, image.dtype, sigmas[1])


def _components(image: np.ndarray, model: tuple, threshold: float, smooth: bool,
                sat_level: float, threads: int) -> np.ndarray:
    """Components of detection > ``threshold`` (``extract_runs``), bands of rows on
    ``threads`` threads."""
    parts = par.bands(image.shape[0], par.parts_for(threads, image.size))
    pieces = par.run(runs.band_runs, [(image, model, threshold, smooth, sat_level, a, b)
                                      for a, b in parts], threads)
    found = np.concatenate([p[0] for p in pieces]) if len(pieces) > 1 else pieces[0][0]
    acc = np.concatenate([p[1] for p in pieces]) if len(pieces) > 1 else pieces[0][1]
    return runs.join_runs(found, acc)


def _mad_sigma(sample: np.ndarray, dtype: np.dtype, sigma: float | None = None) -> float:
    """Noise sigma from the median absolute deviation (stars barely move it); ``sigma``:
    that of ``extract_sky.mad_sigma`` when known."""
    sigma = sky.mad_sigma(sample, _MAD_TO_SIGMA) if sigma is None else sigma
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


def _saturation_level(dtype: np.dtype, level: float | None) -> float | None:
    if level is not None:
        return level
    if np.issubdtype(dtype, np.integer):
        return float(np.iinfo(dtype).max)
    return None


def _empty() -> Centroids:
    return Centroids(np.zeros(0), np.zeros(0), np.zeros(0))
