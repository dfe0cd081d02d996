"""Centroid extraction: a grey frame in, the stars' sub-pixel positions out (compiled core).

Pipeline: sky background removed (tile medians of 4 x 4 block means, interpolated; estimated
twice, the second time without the blocks that held sources); noise from the median absolute
deviation; detection at ``k_sigma`` sigmas on a lightly smoothed copy; 8-connected components;
intensity-weighted centroids of the unsmoothed pixels, background removed; hot pixels and
oversized blobs rejected; saturated spots flagged. Pixels as docs/conventions.md says.

The frame is read twice in full, in its own dtype: once for the block means
(``startrack._core.centroids.background_blocks``, from which the sky model is made; ``sky_grid``
cleans
its tiles) and once, row by row, for detection and moments (``startrack._core.centroids.extract``,
which evaluates the sky model on the fly; ``blobs`` joins the runs and picks the stars).

Threads: the passes over the pixels run on bands of rows at once, on
``CentroidConfig.threads`` threads (default: the cores this process may use, or one when
the load average says they are taken); a frame under ~2 x 65536 px stays on one. The
compiled kernels release the GIL and a thread pool runs them (``centroids._threads``).
Each band writes its own part of a result, and the blobs' runs are joined in raster
order, so the centroids are the same, bit for bit and in the same order, whatever the
thread count.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from startrack._core.centroids import background_blocks as sky_blocks
from startrack._core.centroids import background_grid as sky_grid
from startrack._core.centroids import blobs
from startrack._core.centroids import extract as kern
from startrack.centroids import _threads as par
from startrack.centroids._config import FAST, CentroidConfig  # noqa: F401 (FAST re-exported)
from startrack.centroids._table import Centroids

_MAD_TO_SIGMA = 1.4826
_MASK_SIGMA = 3.0  # blocks above this (grown) are left out of the final sky model
_NO_MASK = np.zeros((0, 0), np.uint8)
_NO_GRID = np.zeros((0, 0))
_NATIVE = (np.uint8, np.uint16, np.int16, np.float32, np.float64)  # kernels take these
#: spots of at least this many pixels have a shape worth measuring (a fainter star's
#: few pixels give its moments no meaning)
SHAPE_MIN_AREA = 9
#: a spot more elongated than this many times the frame's median spot, and than
#: MIN_CUT_ELONGATION, is no star: every star image of a frame shares the optics' blur
#: and any trailing, so a real star is as round (or as trailed) as the others
ELONGATION_FACTOR = 1.6
MIN_CUT_ELONGATION = 2.2
#: spots whose shapes set the frame's typical elongation, at least
SHAPE_SAMPLE = 10




def extract_centroids(image: np.ndarray, config: CentroidConfig | None = None) -> Centroids:
    """Find the stars in a 2-D grey frame (how: the module docstring).

    Parameters
    ----------
    image : numpy.ndarray
        2-D, of any real dtype (uint8, uint16, int16 and float as they are, others as
        float64);
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
    image = _native(image)
    sat_level = _saturation_level(image.dtype, config.saturation)
    threads = par.thread_count(config.threads)
    model = _sky_model(image, config.background_size, config.fast, threads)
    step = max(1, round(math.sqrt(image.size / 25_000)))  # ~2.5e4 px: a MAD to ~1 %
    sigma, sigma_det = _noise(image, model, step, config.smooth, threads)
    comp = _components(image, model, config.k_sigma * sigma_det, config.smooth,
                       np.inf if sat_level is None else sat_level, threads)
    if len(comp) == 0:
        return _empty()

    box = kern.peak_boxes(image, model, comp[:, kern.COLUMNS["peak_at"]])
    # A star's image spreads onto its neighbours; a hot pixel's does not (beyond noise).
    out = Centroids(**blobs.stars(comp, box, config.hot_pixel_fraction,
                                  2.0 * math.sqrt(8.0) * sigma, config.min_area,
                                  *config.area_limits(image.shape)))
    if config.shape_cut:
        unlike = unlike_stars(out)
        if unlike.any():
            out = _keep(out, ~unlike)
    return out if config.max_stars is None else out.brightest(config.max_stars)


def unlike_stars(found: Centroids) -> np.ndarray:
    """Which spots are no star by their shape: of those of at least
    :data:`SHAPE_MIN_AREA` pixels, the ones more elongated than
    :data:`ELONGATION_FACTOR` times the median of them all (and than
    :data:`MIN_CUT_ELONGATION`). Too few measured spots: none."""
    measured = found.area >= SHAPE_MIN_AREA
    if np.count_nonzero(measured) < SHAPE_SAMPLE:
        return np.zeros(len(found), bool)
    typical = float(np.median(found.elongation[measured]))
    cut = max(MIN_CUT_ELONGATION, ELONGATION_FACTOR * typical)
    return measured & (found.elongation > cut)


def _keep(found: Centroids, keep: np.ndarray) -> Centroids:
    return Centroids(found.x[keep], found.y[keep], found.flux[keep], found.saturated[keep],
                     found.area[keep], found.photometric, found.elongation[keep])


def estimate_background(frame: np.ndarray, tile: int,
                        ignore: np.ndarray | None = None) -> np.ndarray:
    """Smooth sky background (float32 image): medians of the 4 x 4 block means of
    ~tile x tile tiles, interpolated.

    Blocks holding a pixel where ``ignore`` is true (known sources) are left out of the
    medians. Two passes: a tile median across a steep gradient is noisy (the gradient
    spreads the tile's values), so the second pass takes the medians of what the first
    left over.
    """
    frame = _native(np.asarray(frame))
    lay, pixel_w, block_w = _geometry(frame.shape, tile)
    means = sky_blocks.block_means(frame, _dead_pixel_fill(frame), lay)
    mask = _NO_MASK
    if ignore is not None:
        ignored = np.ascontiguousarray(ignore, np.uint8)
        mask = (sky_blocks.block_means(ignored, 0.0, lay) > 0).astype(np.uint8)
    raw = sky_blocks.tile_medians(means, mask, lay, _NO_GRID, block_w, _NO_GRID)
    grid = _sky_grid(means, lay, block_w, mask, float(np.median(means)), raw, 1)
    return kern.SkyModel(grid, pixel_w).image()


def _native(image: np.ndarray) -> np.ndarray:
    """``image`` as the compiled kernels read it: a dtype of theirs (else float64), in
    the machine's byte order, C-contiguous."""
    if image.dtype.type not in _NATIVE:
        image = image.astype(np.float64)
    elif not image.dtype.isnative:
        image = image.astype(image.dtype.newbyteorder("="))
    return np.ascontiguousarray(image)


@functools.lru_cache(maxsize=16)
def _geometry(shape: tuple[int, int], tile: int) -> tuple:
    """(Layout, pixel Weights, block Weights) of a frame shape: shared, read only."""
    lay = sky_blocks.Layout(shape[0], shape[1], tile)
    return (lay, *sky_blocks.weights(shape[0], shape[1], lay))


def _sky_model(image: np.ndarray, tile: int, fast: bool, threads: int) -> kern.SkyModel:
    """The sky model of ``image`` from its block means."""
    lay, pixel_w, block_w = _geometry(image.shape, tile)
    means = np.empty(lay.means_shape, np.float32)
    raw = np.empty(lay.grid_shape)
    fill = _dead_pixel_fill(image)
    par.run(sky_blocks.sky_rows, [(image, fill, lay, block_w, a, b, means, raw)
                                  for a, b in _tile_bands(lay, threads, image.size)], threads)
    grid = _sky_grid(means, lay, block_w, _NO_MASK, 0.0, raw, threads)
    if not fast:
        # Twice: the second sky model ignores the blocks the first showed to hold
        # sources, so bright stars and glows do not leak into it (nor, extrapolated, to
        # the border). A block mean is already smoothed: 3 of its sigmas mark a source.
        resid = sky_blocks.residual(means, grid, block_w)
        sources = sky_blocks.sources(resid, _MASK_SIGMA * _mad_sigma(resid[::2, ::2].ravel(),
                                                                     image.dtype))
        masked = _tile_medians(means, sources, lay, _NO_GRID, block_w, raw, threads)
        grid = _sky_grid(means, lay, block_w, sources, sky_grid.median(grid.ravel()), masked,
                         threads)
    return kern.SkyModel(grid, pixel_w)


def _sky_grid(means: np.ndarray, lay: sky_blocks.Layout, block_w: sky_blocks.Weights,
              ignore: np.ndarray, fallback: float, raw: np.ndarray,
              threads: int) -> np.ndarray:
    """Tile values of the two-pass sky model from the block means and their tile medians.

    First the tile medians ``raw``, cleaned of spikes and smoothed; then the median of
    what that model leaves in each tile is added (only despiked), so the model follows
    the sky glow from tile to tile. ``ignore``: blocks left out; ``fallback``: the value
    when every block is.
    """
    grid = sky_grid.clean_grid(raw, True, fallback)
    extra = _tile_medians(means, ignore, lay, grid, block_w, _NO_GRID, threads)
    return grid + sky_grid.clean_grid(extra, False, 0.0)


def _tile_bands(lay: sky_blocks.Layout, threads: int, pixels: int) -> list[tuple[int, int]]:
    return par.bands(lay.tiles_down, par.parts_for(threads, pixels))  # of tile rows


def _tile_medians(means: np.ndarray, ignore: np.ndarray, lay: sky_blocks.Layout,
                  grid: np.ndarray, block_w: sky_blocks.Weights, known: np.ndarray,
                  threads: int) -> np.ndarray:
    """``sky_blocks.tile_medians``, bands of tile rows on ``threads`` threads."""
    out = np.empty(lay.grid_shape)
    par.run(sky_blocks.tile_rows, [(means, ignore, lay, grid, block_w, known, a, b, out)
                                   for a, b in _tile_bands(lay, threads, 16 * means.size)],
            threads)
    return out


def _noise(image: np.ndarray, model: kern.SkyModel, step: int, smooth: bool,
           threads: int) -> tuple[float, float]:
    """Noise sigma of the residual and of the detection image, from samples on the grid
    [::step, ::step]."""
    n_rows, n_cols = -(-image.shape[0] // step), -(-image.shape[1] // step)
    res, det = np.empty(n_rows * n_cols), np.empty(n_rows * n_cols)
    parts = par.bands(n_rows, par.parts_for(threads, 9 * res.size))
    par.run(kern.samples, [(image, model, step, smooth, a, b, res, det) for a, b in parts],
            threads)
    sigmas = par.run(sky_grid.mad_sigma, [(res, _MAD_TO_SIGMA), (det, _MAD_TO_SIGMA)],
                     threads)
    return _mad_sigma(res, image.dtype, sigmas[0]), _mad_sigma(det, image.dtype, sigmas[1])


def _components(image: np.ndarray, model: kern.SkyModel, threshold: float, smooth: bool,
                sat_level: float, threads: int) -> np.ndarray:
    """Components of detection > ``threshold`` (``extract.band_runs`` joined by
    ``blobs.join_runs``), bands of rows on ``threads`` threads."""
    parts = par.bands(image.shape[0], par.parts_for(threads, image.size))
    pieces = par.run(kern.band_runs, [(image, model, threshold, smooth, sat_level, a, b)
                                      for a, b in parts], threads)
    found = np.concatenate([p[0] for p in pieces]) if len(pieces) > 1 else pieces[0][0]
    acc = np.concatenate([p[1] for p in pieces]) if len(pieces) > 1 else pieces[0][1]
    return blobs.join_runs(found, acc)


def _mad_sigma(sample: np.ndarray, dtype: np.dtype, sigma: float | None = None) -> float:
    """Noise sigma from the median absolute deviation (stars barely move it); ``sigma``:
    that of ``sky_grid.mad_sigma`` when known."""
    if sigma is None:
        sigma = sky_grid.mad_sigma(np.asarray(sample, np.float64), _MAD_TO_SIGMA)
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
