"""The centroider's sky model from a block-mean image: one pass over the frame, then small.

Each background tile is cut into square blocks (4 x 4 px where tiles allow); one pass over
the frame gives every block's mean, and the sky model is made from those alone: tile
medians of the block means, the residual left in each tile, and the source mask of the
second estimate (blocks standing out, grown by one block). A block mean holds every pixel
of its block, so a tile median over ~50 blocks is less noisy than one over hundreds of
single sampled pixels, and the passes after the first touch 1/16 of the data. The tile
grid's clean-up is in ``sky_grid``; ``extract`` evaluates the model at the pixels.
"""

import numpy as np

from libc.math cimport NAN, floor, isfinite
from libc.stdint cimport int32_t, uint8_t

from startrack._core.centroids.median cimport middle as _middle
from startrack._core.centroids.pixels cimport pixel_t

BLOCK = 4  # px, side of a block where tiles are at least two blocks across
_NO_GRID = np.zeros((0, 0))
_NO_MASK = np.zeros((0, 0), np.uint8)


cdef class Layout:
    """Tiles and blocks of a frame: tiles down and across, tile height and width, row and
    column of the first block, block side, blocks down and across a tile (the blocks are
    centred in a tile)."""

    cdef readonly Py_ssize_t tiles_down, tiles_across, tile_h, tile_w
    cdef readonly Py_ssize_t first_row, first_col, block, blocks_down, blocks_across

    def __init__(self, Py_ssize_t h, Py_ssize_t w, Py_ssize_t tile):
        self.tiles_down, self.tiles_across = max(1, h // tile), max(1, w // tile)
        self.tile_h, self.tile_w = h // self.tiles_down, w // self.tiles_across
        self.block = BLOCK if min(self.tile_h, self.tile_w) >= 2 * BLOCK else 1
        self.blocks_down = self.tile_h // self.block
        self.blocks_across = self.tile_w // self.block
        self.first_row = ((h - self.tiles_down * self.tile_h) // 2
                          + (self.tile_h - self.blocks_down * self.block) // 2)
        self.first_col = ((w - self.tiles_across * self.tile_w) // 2
                          + (self.tile_w - self.blocks_across * self.block) // 2)

    @property
    def means_shape(self):
        """(rows, columns) of the block-mean image."""
        return (self.tiles_down * self.blocks_down, self.tiles_across * self.blocks_across)

    @property
    def grid_shape(self):
        """(rows, columns) of the tile grid."""
        return (self.tiles_down, self.tiles_across)


def _interp(pos, Py_ssize_t n_tiles, Py_ssize_t pitch, double first):
    """At each position: the lower and upper of two tiles and the weight of the upper;
    tile i is centred at ``first + i * pitch``, and beyond the outer centres the weight
    leaves [0, 1] (linear extrapolation)."""
    if n_tiles == 1:
        zero = np.zeros(len(pos), np.int64)
        return zero, zero, np.zeros(len(pos))
    t = (np.asarray(pos, np.float64) - first) / pitch
    lo = np.clip(np.floor(t).astype(np.int64), 0, n_tiles - 2)
    return lo, lo + 1, t - lo


cdef class Weights:
    """Bilinear weights of the tile grid along rows and columns: per row, the lower and
    upper tile row and the upper's weight (``row_lo``, ``row_hi``, ``row_t``); the same
    per column. Read only: shared by the frames of one shape."""

    cdef readonly object row_lo, row_hi, row_t, col_lo, col_hi, col_t

    def __init__(self, Layout lay, rows, cols):
        first_r = lay.first_row + (lay.blocks_down * lay.block - 1) / 2
        first_c = lay.first_col + (lay.blocks_across * lay.block - 1) / 2
        self.row_lo, self.row_hi, self.row_t = _interp(rows, lay.tiles_down, lay.tile_h,
                                                       first_r)
        self.col_lo, self.col_hi, self.col_t = _interp(cols, lay.tiles_across, lay.tile_w,
                                                       first_c)
        for a in (self.row_lo, self.row_hi, self.row_t, self.col_lo, self.col_hi, self.col_t):
            a.flags.writeable = False


def _centres(Py_ssize_t n_tiles, Py_ssize_t pitch, Py_ssize_t origin, Py_ssize_t b,
             Py_ssize_t n_blocks):
    tiles = origin + pitch * np.arange(n_tiles)[:, None]
    return (tiles + b * np.arange(n_blocks)[None, :] + (b - 1) / 2).ravel()


def weights(Py_ssize_t h, Py_ssize_t w, Layout lay):
    """(pixel, block) ``Weights``: at every pixel row and column, and at the blocks'
    centres. A tile's value stands where the centre of its blocks is."""
    pixel = Weights(lay, np.arange(h), np.arange(w))
    block = Weights(lay, _centres(lay.tiles_down, lay.tile_h, lay.first_row, lay.block,
                                  lay.blocks_down),
                    _centres(lay.tiles_across, lay.tile_w, lay.first_col, lay.block,
                             lay.blocks_across))
    return pixel, block


cdef void _block_rows(const pixel_t[:, ::1] image, double fill, Layout lay, Py_ssize_t i_start,
                      Py_ssize_t i_stop, float[:, ::1] out, double[::1] acc,
                      int32_t[::1] total) noexcept nogil:
    """Block means of tile rows ``i_start`` .. ``i_stop - 1`` into their rows of ``out``;
    rows are summed first, along contiguous memory. An integer frame's sums stay integers
    (the same, exact sums, but twice as many to a vector instruction)."""
    cdef Py_ssize_t i, k, r, d, c, j, m, e, b = lay.block, w = image.shape[1]
    cdef double inv = 1.0 / (b * b), s, v
    cdef long long t
    for i in range(i_start, i_stop):
        for k in range(lay.blocks_down):
            r = lay.first_row + i * lay.tile_h + k * b
            if pixel_t is float or pixel_t is double:
                acc[:] = 0.0
                for d in range(b):
                    for c in range(w):
                        v = <double>image[r + d, c]
                        acc[c] += v if isfinite(v) else fill
            else:
                total[:] = 0
                for d in range(b):
                    for c in range(w):
                        total[c] += <int32_t>image[r + d, c]
            for j in range(lay.tiles_across):
                for m in range(lay.blocks_across):
                    c = lay.first_col + j * lay.tile_w + m * b
                    if pixel_t is float or pixel_t is double:
                        s = 0.0
                        for e in range(b):
                            s += acc[c + e]
                        out[i * lay.blocks_down + k, j * lay.blocks_across + m] = s * inv
                    else:
                        t = 0
                        for e in range(b):
                            t += total[c + e]
                        out[i * lay.blocks_down + k, j * lay.blocks_across + m] = <double>t * inv


cdef inline void _model_row(const double[:, ::1] grid, const long long[::1] lo,
                            const long long[::1] hi, const double[::1] t, Py_ssize_t k,
                            double[::1] row) noexcept nogil:
    """Row ``k`` of the tile grid blended along the rows."""
    cdef Py_ssize_t j
    for j in range(grid.shape[1]):
        row[j] = grid[lo[k], j] * (1.0 - t[k]) + grid[hi[k], j] * t[k]


cdef class _TileScratch:
    """Work arrays of one band's tile medians."""
    cdef double[::1] buf, row
    cdef double[:, ::1] bg
    cdef long long[::1] counts

    def __init__(self, Layout lay, Py_ssize_t means_w, Py_ssize_t grid_w):
        self.buf = np.empty(lay.blocks_down * lay.blocks_across)
        self.row = np.empty(grid_w)
        self.bg = np.zeros((lay.blocks_down, means_w))
        self.counts = np.empty(256, np.int64)


cdef bint _any(const uint8_t[:, ::1] mask, Py_ssize_t r0, Py_ssize_t r1, Py_ssize_t c0,
               Py_ssize_t c1) noexcept nogil:
    cdef Py_ssize_t r, c
    for r in range(r0, r1):
        for c in range(c0, c1):
            if mask[r, c]:
                return True
    return False


cdef void _tile_rows(const float[:, ::1] means, const uint8_t[:, ::1] ignore, Layout lay,
                     const double[:, ::1] grid, Weights bw, const double[:, ::1] known,
                     Py_ssize_t i_start, Py_ssize_t i_stop, double[:, ::1] out,
                     _TileScratch s) noexcept:
    """Tile medians of tile rows ``i_start`` .. ``i_stop - 1`` (see ``tile_medians``)."""
    cdef const long long[::1] r0 = bw.row_lo, r1 = bw.row_hi, c0 = bw.col_lo, c1 = bw.col_hi
    cdef const double[::1] fr = bw.row_t, fc = bw.col_t
    cdef Py_ssize_t nb_r = lay.blocks_down, nb_c = lay.blocks_across, i, j, k, m, n
    cdef bint use_ignore = ignore.shape[0] > 0, subtract = grid.shape[0] > 0
    with nogil:
        for i in range(i_start, i_stop):
            for k in range(nb_r * subtract):  # the model along this row of tiles' blocks
                _model_row(grid, r0, r1, fr, i * nb_r + k, s.row)
                for m in range(means.shape[1]):
                    s.bg[k, m] = s.row[c0[m]] * (1.0 - fc[m]) + s.row[c1[m]] * fc[m]
            for j in range(means.shape[1] // nb_c):
                if use_ignore and known.shape[0] > 0 and not _any(
                        ignore, i * nb_r, (i + 1) * nb_r, j * nb_c, (j + 1) * nb_c):
                    out[i, j] = known[i, j]
                    continue
                n = 0
                for k in range(nb_r):
                    for m in range(j * nb_c, (j + 1) * nb_c):
                        s.buf[n] = means[i * nb_r + k, m] - s.bg[k, m]
                        n += not (use_ignore and ignore[i * nb_r + k, m])  # no branch on it
                out[i, j] = _middle(s.buf, n, s.counts) if n > 0 else NAN


def block_means(const pixel_t[:, ::1] image, double fill, Layout lay):
    """Mean of every block (float32: plenty for a sky model); non-finite pixels count as
    ``fill``."""
    out = np.empty(lay.means_shape, np.float32)
    cdef float[:, ::1] means = out
    cdef double[::1] acc = np.empty(image.shape[1])
    cdef int32_t[::1] total = np.empty(image.shape[1], np.int32)
    with nogil:
        _block_rows(image, fill, lay, 0, lay.tiles_down, means, acc, total)
    return out


def sky_rows(const pixel_t[:, ::1] image, double fill, Layout lay, Weights block_w,
             Py_ssize_t i_start, Py_ssize_t i_stop, float[:, ::1] means, double[:, ::1] raw):
    """The first pass of the sky model over tile rows ``i_start`` .. ``i_stop - 1``: their
    block means into ``means`` and their plain tile medians into ``raw``."""
    cdef double[::1] acc = np.empty(image.shape[1])
    cdef int32_t[::1] total = np.empty(image.shape[1], np.int32)
    with nogil:
        _block_rows(image, fill, lay, i_start, i_stop, means, acc, total)
    _tile_rows(means, _NO_MASK, lay, _NO_GRID, block_w, _NO_GRID, i_start, i_stop, raw,
               _TileScratch(lay, means.shape[1], 0))


def tile_rows(const float[:, ::1] means, const uint8_t[:, ::1] ignore, Layout lay,
              const double[:, ::1] grid, Weights block_w, const double[:, ::1] known,
              Py_ssize_t i_start, Py_ssize_t i_stop, double[:, ::1] out):
    """Median over each tile's blocks of ``means`` minus the sky model of tile values
    ``grid`` (none when empty), for tile rows ``i_start`` .. ``i_stop - 1`` into ``out``;
    blocks where ``ignore`` (when not empty) is non-zero are left out, NaN where every
    one is. ``known``, when not empty, holds the medians without ``ignore``: a tile with
    no ignored block takes its value."""
    _tile_rows(means, ignore, lay, grid, block_w, known, i_start, i_stop, out,
               _TileScratch(lay, means.shape[1], grid.shape[1]))


def tile_medians(means, ignore, Layout lay, grid, Weights block_w, known):
    """``tile_rows`` of every tile row, in a new (tiles down x across) array."""
    out = np.empty(lay.grid_shape)
    tile_rows(means, ignore, lay, grid, block_w, known, 0, lay.tiles_down, out)
    return out


def residual(const float[:, ::1] means, const double[:, ::1] grid, Weights block_w):
    """Block means minus the sky model (tile values ``grid``, bilinear) at the blocks'
    centres (float32)."""
    cdef const long long[::1] r0 = block_w.row_lo, r1 = block_w.row_hi
    cdef const long long[::1] c0 = block_w.col_lo, c1 = block_w.col_hi
    cdef const double[::1] fr = block_w.row_t, fc = block_w.col_t
    res = np.empty((means.shape[0], means.shape[1]), np.float32)
    cdef float[:, ::1] out = res
    cdef double[::1] row = np.empty(grid.shape[1])
    cdef Py_ssize_t k, m
    with nogil:
        for k in range(r0.shape[0]):
            _model_row(grid, r0, r1, fr, k, row)
            for m in range(c0.shape[0]):
                out[k, m] = means[k, m] - (row[c0[m]] * (1.0 - fc[m]) + row[c1[m]] * fc[m])
    return res


def sources(const float[:, ::1] resid, double threshold):
    """The blocks whose ``resid`` exceeds ``threshold`` (compared in float32, as numpy
    compares a float32 array with a number) and their 8 neighbours, as a uint8 mask:
    ``cv2.dilate`` of the comparison with a 3 x 3 square."""
    cdef float t = <float>threshold
    cdef Py_ssize_t h = resid.shape[0], w = resid.shape[1], i, j, a, b
    mask = np.zeros((h, w), np.uint8)
    cdef uint8_t[:, ::1] out = mask
    with nogil:
        for i in range(h):
            for j in range(w):
                if resid[i, j] > t:
                    for a in range(max(i - 1, 0), min(i + 2, h)):
                        for b in range(max(j - 1, 0), min(j + 2, w)):
                            out[a, b] = 1
    return mask

