"""The centroider's sky model from a block-mean image: one pass over the frame, then small.

Each background tile is cut into square blocks (4 x 4 px where tiles allow); one pass over
the frame gives every block's mean, and the sky model is made from those alone: tile
medians of the block means, their clean-up, the residual left in each tile, and the
source mask of the second estimate (blocks standing out, grown by one block). A block
mean holds every pixel of its block, so a tile median over ~50 blocks is less noisy than
one over hundreds of single sampled pixels, and the model's passes after the first touch
1/16 of the data. The pixel-row kernels of ``extract_kernels`` then evaluate the model.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from numba import njit, types
from numba.extending import overload

from startrack.extract_sky import middle

BLOCK = 4  # px, side of a block where tiles are at least two blocks across


@functools.lru_cache(maxsize=16)
def layout(shape: tuple[int, int], tile: int) -> tuple:
    """(tiles down, tiles across, tile height, tile width, row and column of the first
    block, block side, blocks down and across a tile); the blocks are centred in a tile."""
    h, w = shape
    n_r, n_c = max(1, h // tile), max(1, w // tile)
    t_r, t_c = h // n_r, w // n_c
    b = BLOCK if min(t_r, t_c) >= 2 * BLOCK else 1
    nb_r, nb_c = t_r // b, t_c // b
    o_r = (h - n_r * t_r) // 2 + (t_r - nb_r * b) // 2
    o_c = (w - n_c * t_c) // 2 + (t_c - nb_c * b) // 2
    return n_r, n_c, t_r, t_c, o_r, o_c, b, nb_r, nb_c


def interp_weights(pos: np.ndarray, n_tiles: int, pitch: int, first: float) -> tuple:
    """At each position: the lower and upper of two tiles and the weight of the upper.

    Tile i is centred at ``first + i * pitch``; beyond the outer centres the weight leaves
    [0, 1], which extrapolates linearly.
    """
    if n_tiles == 1:
        zero = np.zeros(len(pos), np.int64)
        return zero, zero, np.zeros(len(pos))
    t = (np.asarray(pos, np.float64) - first) / pitch
    i0 = np.clip(np.floor(t).astype(np.int64), 0, n_tiles - 2)
    return i0, i0 + 1, t - i0


@functools.lru_cache(maxsize=16)
def weights(shape: tuple[int, int], lay: tuple) -> tuple[tuple, tuple]:
    """Interpolation weights (r0, r1, fr, c0, c1, fc) for every pixel row and column, and
    for every block row and column (at the blocks' centres). A tile's value stands where
    the centre of its blocks is. Cached by frame shape (the arrays are shared: read only)."""
    n_r, n_c, t_r, t_c, o_r, o_c, b, nb_r, nb_c = lay
    first_r, first_c = o_r + (nb_r * b - 1) / 2, o_c + (nb_c * b - 1) / 2

    def both(rows, cols):
        return interp_weights(rows, n_r, t_r, first_r) + interp_weights(cols, n_c, t_c, first_c)

    pixel = both(np.arange(shape[0]), np.arange(shape[1]))
    block = both(_centres(n_r, t_r, o_r, b, nb_r), _centres(n_c, t_c, o_c, b, nb_c))
    for a in pixel + block:
        a.flags.writeable = False
    return pixel, block


def _centres(n_tiles: int, pitch: int, origin: int, b: int, n_blocks: int) -> np.ndarray:
    tiles = origin + pitch * np.arange(n_tiles)[:, None]
    return (tiles + b * np.arange(n_blocks)[None, :] + (b - 1) / 2).ravel()


@njit(cache=True, nogil=True)
def _model_row(grid, r0, r1, fr, k, row):
    """Row ``k`` of the block model's tile rows: the tile grid blended along the rows."""
    for j in range(grid.shape[1]):
        row[j] = grid[r0[k], j] * (1.0 - fr[k]) + grid[r1[k], j] * fr[k]


@njit(cache=True, nogil=True)
def residual(means, grid, r0, r1, fr, c0, c1, fc):
    """Block means minus the sky model (tile values ``grid``, bilinear) at the blocks'
    centres (float32); the arguments after ``grid`` are the block weights of ``weights``."""
    out = np.empty(means.shape, np.float32)
    row = np.empty(grid.shape[1])
    for k in range(len(r0)):
        _model_row(grid, r0, r1, fr, k, row)
        for m in range(len(c0)):
            out[k, m] = means[k, m] - (row[c0[m]] * (1.0 - fc[m]) + row[c1[m]] * fc[m])
    return out


@njit(cache=True, nogil=True)
def sources(resid, threshold):
    """The blocks whose ``resid`` exceeds ``threshold`` (compared in float32, as numpy
    compares a float32 array with a number) and their 8 neighbours, as a uint8 mask:
    ``cv2.dilate`` of the comparison with a 3 x 3 square, without its temporaries."""
    t = np.float32(threshold)
    h, w = resid.shape
    out = np.zeros((h, w), np.uint8)
    for i in range(h):
        for j in range(w):
            if resid[i, j] > t:
                out[max(i - 1, 0):i + 2, max(j - 1, 0):j + 2] = 1
    return out


@njit(cache=True, nogil=True)
def block_means(image, fill, lay):
    """Mean of every block (blocks down x blocks across, float32: plenty for a sky
    model); non-finite pixels count as ``fill``."""
    out = np.empty((lay[0] * lay[7], lay[1] * lay[8]), np.float32)
    block_rows(image, fill, lay, 0, lay[0], out)
    return out


@njit(cache=True, nogil=True)
def block_rows(image, fill, lay, i_start, i_stop, out):
    """``block_means`` of tile rows ``i_start`` .. ``i_stop - 1`` into their rows of
    ``out``. Rows are summed first: the inner loops run along contiguous memory.

    An integer frame's sums are kept as integers: the same sums as in floats (exact
    either way, far below 2**53), but integer additions pack twice as many to a vector
    instruction and a block's four make no chain of float latencies.
    """
    n_r, n_c, t_r, t_c, o_r, o_c, b, nb_r, nb_c = lay
    w = image.shape[1]
    integer = _integer(image)  # known when compiled: the other branch is left out
    acc, total = np.empty(w), np.empty(w, np.int32)
    inv = 1.0 / (b * b)
    for i in range(i_start, i_stop):
        for k in range(nb_r):
            r = o_r + i * t_r + k * b
            if integer:
                _integer_rows(image, r, b, total)
            else:
                acc[:] = 0.0
                for d in range(b):
                    for c in range(w):
                        v = float(image[r + d, c])
                        acc[c] += v if math.isfinite(v) else fill
            for j in range(n_c):
                for m in range(nb_c):
                    c = o_c + j * t_c + m * b
                    if integer:
                        t = 0
                        for e in range(b):
                            t += total[c + e]
                        out[i * nb_r + k, j * nb_c + m] = float(t) * inv
                        continue
                    s = 0.0
                    for e in range(b):
                        s += acc[c + e]
                    out[i * nb_r + k, j * nb_c + m] = s * inv


@njit(cache=True, nogil=True)
def _integer_rows(image, r, b, total):
    """Rows ``r`` .. ``r + b - 1`` of an integer frame (at most 16 bits) summed, column
    by column (int32: a block's sum of up to 16 such values fits)."""
    total[:] = 0
    for d in range(b):
        for c in range(total.shape[0]):
            total[c] += np.int32(image[r + d, c])


def _integer(image) -> bool:
    """Whether ``image`` holds integers; in a compiled kernel, a constant."""
    return np.issubdtype(image.dtype, np.integer)


@overload(_integer)
def _integer_kernel(image):
    value = isinstance(image.dtype, types.Integer)
    return lambda image: value


@njit(cache=True, nogil=True)
def sky_rows(image, fill, lay, block_w, i_start, i_stop, means, raw):
    """The first pass of the sky model over tile rows ``i_start`` .. ``i_stop - 1``: their
    block means into ``means`` and their plain tile medians into ``raw``."""
    block_rows(image, fill, lay, i_start, i_stop, means)
    none = np.zeros((0, 0))
    tile_rows(means, np.zeros((0, 0), np.uint8), lay[7], lay[8], none, block_w, none,
              i_start, i_stop, raw)


@njit(cache=True, nogil=True)
def tile_medians(means, ignore, nb_r, nb_c, grid, block_w, known):
    """Median over each tile's blocks of ``means`` (blocks down x across) minus the sky
    model of tile values ``grid`` (none when it is empty; ``block_w``: the block weights
    of ``weights``), leaving out blocks where ``ignore`` (when not empty) is non-zero;
    NaN where every one is. ``known``, when not empty, holds the medians of the same
    call without ``ignore``: a tile with no ignored block takes its value."""
    out = np.empty((means.shape[0] // nb_r, means.shape[1] // nb_c))
    tile_rows(means, ignore, nb_r, nb_c, grid, block_w, known, 0, out.shape[0], out)
    return out


@njit(cache=True, nogil=True)
def tile_rows(means, ignore, nb_r, nb_c, grid, block_w, known, i_start, i_stop, out):
    """``tile_medians`` of tile rows ``i_start`` .. ``i_stop - 1`` into their rows of
    ``out``."""
    r0, r1, fr, c0, c1, fc = block_w
    n_c = means.shape[1] // nb_c
    buf = np.empty(nb_r * nb_c)
    counts = np.empty(256, np.int64)
    use_ignore, subtract = ignore.shape[0] > 0, grid.shape[0] > 0
    row, bg = np.empty(grid.shape[1]), np.zeros((nb_r, means.shape[1]))
    for i in range(i_start, i_stop):
        for k in range(nb_r * subtract):  # the model along this row of tiles' blocks
            _model_row(grid, r0, r1, fr, i * nb_r + k, row)
            for m in range(means.shape[1]):
                bg[k, m] = row[c0[m]] * (1.0 - fc[m]) + row[c1[m]] * fc[m]
        for j in range(n_c):
            if use_ignore and known.shape[0] > 0 \
                    and not ignore[i * nb_r:(i + 1) * nb_r, j * nb_c:(j + 1) * nb_c].any():
                out[i, j] = known[i, j]
                continue
            n = 0
            for k in range(nb_r):
                for m in range(j * nb_c, (j + 1) * nb_c):
                    buf[n] = means[i * nb_r + k, m] - bg[k, m]
                    n += not (use_ignore and ignore[i * nb_r + k, m])  # no branch on it
            out[i, j] = middle(buf, n, counts) if n > 0 else np.nan
