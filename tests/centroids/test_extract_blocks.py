"""The centroider's block-mean sky kernels and run finder against plain numpy references."""

import numpy as np
import pytest
from startrack._core.centroids.extract import row_runs as _row_runs

from startrack._core.centroids import background_blocks as blocks

NO_GRID = np.zeros((0, 0))
NO_MASK = np.zeros((0, 0), np.uint8)


def layout(shape, tile):
    return blocks.Layout(shape[0], shape[1], tile)


def weights(shape, lay):
    return blocks.weights(shape[0], shape[1], lay)


def unpack(w):
    return w.row_lo, w.row_hi, w.row_t, w.col_lo, w.col_hi, w.col_t


def reference_means(image, lay, fill=0.0):
    """Block means by reshaping the blocks' pixels (tiles laid out as in ``Layout``)."""
    n_r, n_c, t_r, t_c = lay.tiles_down, lay.tiles_across, lay.tile_h, lay.tile_w
    o_r, o_c, b, nb_r, nb_c = (lay.first_row, lay.first_col, lay.block, lay.blocks_down,
                               lay.blocks_across)
    image = np.where(np.isfinite(image), image, fill).astype(np.float64)
    out = np.empty((n_r * nb_r, n_c * nb_c))
    for i in range(n_r):
        for j in range(n_c):
            r, c = o_r + i * t_r, o_c + j * t_c
            tile = image[r:r + nb_r * b, c:c + nb_c * b]
            out[i * nb_r:(i + 1) * nb_r, j * nb_c:(j + 1) * nb_c] = \
                tile.reshape(nb_r, b, nb_c, b).mean(axis=(1, 3))
    return out


@pytest.mark.parametrize("shape,tile", [((200, 260), 31), ((97, 131), 16), ((40, 50), 5)])
def test_block_means_match_numpy(shape, tile):
    rng = np.random.default_rng(shape[0])
    image = rng.integers(0, 65535, shape).astype(np.uint16)
    lay = layout(shape, tile)
    n_r, n_c, t_r, t_c = lay.tiles_down, lay.tiles_across, lay.tile_h, lay.tile_w
    o_r, o_c, b = lay.first_row, lay.first_col, lay.block
    assert b == (4 if min(t_r, t_c) >= 8 else 1)
    assert o_r >= 0 and o_c >= 0
    assert o_r + n_r * t_r <= shape[0] and o_c + n_c * t_c <= shape[1]
    got = blocks.block_means(image, 0.0, lay)
    np.testing.assert_allclose(got, reference_means(image, lay), rtol=1e-6)
    floats = rng.normal(100.0, 5.0, shape)
    floats[3:9, 10:14] = np.nan
    np.testing.assert_allclose(blocks.block_means(floats, 42.0, lay),
                               reference_means(floats, lay, 42.0), rtol=1e-6)


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.int16])
def test_integer_block_sums_equal_the_float_ones_bit_for_bit(dtype):
    """Integer frames are summed in integers: the same block means as the frame in floats,
    to the last bit, at the dtype's extremes too."""
    rng = np.random.default_rng(7)
    info = np.iinfo(dtype)
    image = rng.integers(info.min, info.max, (131, 170), endpoint=True).astype(dtype)
    image[:40, :40] = info.max
    image[40:80, :40] = info.min
    for tile in (31, 7):
        lay = layout(image.shape, tile)
        np.testing.assert_array_equal(blocks.block_means(image, 0.0, lay),
                                      blocks.block_means(image.astype(np.float64), 0.0, lay))


def test_source_mask_is_the_dilated_comparison():
    """blocks.sources: numpy's float32 comparison, grown by cv2.dilate's 3 x 3 square (up
    to the edges), including a value between the threshold and its float32 rounding."""
    import cv2

    rng = np.random.default_rng(11)
    threshold = 2.7000000001  # not a float32: compared in float64, float32(it) > it
    for shape in ((1, 1), (2, 7), (40, 53)):
        resid = rng.normal(0.0, 1.0, shape).astype(np.float32)
        resid.flat[::5] = np.float32(threshold)
        resid[0, 0], resid[-1, -1] = 9.0, 9.0  # corners
        want = cv2.dilate((resid > threshold).astype(np.uint8), np.ones((3, 3), np.uint8))
        np.testing.assert_array_equal(blocks.sources(resid, threshold), want)


def test_tile_medians_match_numpy_with_mask_model_and_known():
    rng = np.random.default_rng(5)
    shape, tile = (200, 260), 31
    lay = layout(shape, tile)
    nb_r, nb_c = lay.blocks_down, lay.blocks_across
    _, block_w = weights(shape, lay)
    means = rng.normal(0.0, 3.0, lay.means_shape).astype(np.float32)
    grid = rng.normal(10.0, 2.0, lay.grid_shape)
    model = means - blocks.residual(means, grid, block_w)  # the model at the blocks
    r0, r1, fr, c0, c1, fc = unpack(block_w)
    rows = grid[r0] * (1 - fr)[:, None] + grid[r1] * fr[:, None]
    np.testing.assert_allclose(model, rows[:, c0] * (1 - fc) + rows[:, c1] * fc, atol=1e-4)
    ignore = (rng.random(means.shape) < 0.3).astype(np.uint8)
    ignore[:nb_r, :nb_c] = 1  # a tile with every block ignored

    def tiles(values, mask):
        out = np.full(lay.grid_shape, np.nan)
        for i in range(lay.tiles_down):
            for j in range(lay.tiles_across):
                v = values[i * nb_r:(i + 1) * nb_r, j * nb_c:(j + 1) * nb_c]
                keep = mask[i * nb_r:(i + 1) * nb_r, j * nb_c:(j + 1) * nb_c] == 0
                if keep.any():
                    out[i, j] = np.median(v[keep].astype(np.float64))
        return out

    none = np.zeros(means.shape, np.uint8)
    plain = blocks.tile_medians(means, NO_MASK, lay, NO_GRID, block_w, NO_GRID)
    np.testing.assert_array_equal(plain, tiles(means, none))
    masked = blocks.tile_medians(means, ignore, lay, NO_GRID, block_w, NO_GRID)
    np.testing.assert_array_equal(masked, tiles(means, ignore))
    assert np.isnan(masked[0, 0]) and np.isfinite(masked[1:, 1:]).all()
    sub = blocks.tile_medians(means, ignore, lay, grid, block_w, NO_GRID)
    np.testing.assert_allclose(sub, tiles(means - model, ignore), atol=1e-4)
    # known medians are taken as they are where no block of a tile is ignored
    sparse = np.zeros_like(ignore)
    sparse[nb_r + 1, 2 * nb_c + 3] = 1
    known = np.full(lay.grid_shape, -7.0)
    reused = blocks.tile_medians(means, sparse, lay, NO_GRID, block_w, known)
    assert reused[1, 2] == tiles(means, sparse)[1, 2]
    assert np.all(np.delete(reused.ravel(), 1 * lay.tiles_across + 2) == -7.0)


def test_block_weights_put_each_tile_value_at_its_blocks_centre():
    shape, tile = (200, 260), 31
    lay = layout(shape, tile)
    pixel_w, block_w = weights(shape, lay)
    rows, cols = np.mgrid[0:shape[0], 0:shape[1]]
    plane = 5.0 + 0.3 * cols - 0.7 * rows
    means = blocks.block_means(plane, 0.0, lay)
    grid = blocks.tile_medians(means, NO_MASK, lay, NO_GRID, block_w, NO_GRID)
    # a plane's tile medians are the plane at the tiles' centres: bilinear is exact
    np.testing.assert_allclose(blocks.residual(means, grid, block_w), 0.0, atol=1e-3)
    r0, r1, fr, c0, c1, fc = unpack(pixel_w)
    at = grid[r0] * (1 - fr)[:, None] + grid[r1] * fr[:, None]
    np.testing.assert_allclose(at[:, c0] * (1 - fc) + at[:, c1] * fc, plane, atol=1e-3)


def reference_runs(det, threshold):
    above = np.r_[False, det > threshold, False]
    edges = np.flatnonzero(np.diff(above.astype(np.int8)))
    return list(zip(edges[::2], edges[1::2] - 1, strict=True))


@pytest.mark.parametrize("w", [1, 31, 32, 33, 64, 100, 1024])
def test_row_runs_match_numpy_across_chunk_edges(w):
    rng = np.random.default_rng(w)
    out = np.empty((2, w // 2 + 1), np.int64)
    for density in (0.0, 0.02, 0.3, 0.7, 1.0):
        det = np.where(rng.random(w) < density, 5.0, 0.0)
        if w > 40:
            det[30:35] = 5.0  # a run across the first chunk edge
        n = _row_runs(det, 1.0, out)
        assert list(zip(out[0, :n], out[1, :n], strict=True)) == reference_runs(det, 1.0)
