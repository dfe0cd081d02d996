"""The compiled core's extraction, render, parse and prediction kernels held to the numba
kernels they replace, bit for bit, on seeded random inputs and a real frame."""

import numpy as np
import pytest

from startrack import extract_blocks as nb_blocks
from startrack import extract_grid as nb_grid
from startrack import extract_kernels as nb_kern
from startrack import extract_runs as nb_runs
from startrack import extract_sky as nb_sky
from startrack import prediction_kernels as nb_pred
from startrack import render_kernels as nb_render
from startrack._core import blobs, extract, parse, predict, render, sky_blocks, sky_grid
from startrack.imageio import read_image
from startrack.sky import parse_kernels as nb_parse

DTYPES = (np.uint8, np.uint16, np.int16, np.float32, np.float64)
NO_GRID = np.zeros((0, 0))
NO_MASK = np.zeros((0, 0), np.uint8)


def frame(dtype, shape, seed):
    rng = np.random.default_rng(seed)
    if np.issubdtype(dtype, np.integer):
        info = np.iinfo(dtype)
        img = rng.normal(info.min / 2 + info.max / 4, 9.0, shape)
        img[rng.random(shape) < 0.01] += 300
        return np.clip(img, info.min, info.max).astype(dtype)
    img = rng.normal(100.0, 5.0, shape).astype(dtype)
    img[rng.random(shape) < 0.01] += 300
    img[3:9, 10:14] = np.nan
    img[20, 5] = np.inf
    return img


def old_layout(lay):
    return (lay.tiles_down, lay.tiles_across, lay.tile_h, lay.tile_w, lay.first_row,
            lay.first_col, lay.block, lay.blocks_down, lay.blocks_across)


def weights_tuple(w):
    return (w.row_lo, w.row_hi, w.row_t, w.col_lo, w.col_hi, w.col_t)


def models(shape, tile, seed):
    """(numba model tuple, compiled SkyModel, layouts, block weights) of a random grid."""
    lay = sky_blocks.Layout(*shape, tile)
    pix, blk = sky_blocks.weights(*shape, lay)
    old = nb_blocks.layout(shape, tile)
    assert old == old_layout(lay)
    old_pix, old_blk = nb_blocks.weights(shape, old)
    for a, b in zip(old_pix + old_blk, weights_tuple(pix) + weights_tuple(blk), strict=True):
        np.testing.assert_array_equal(a, b)
    grid = np.random.default_rng(seed).normal(50.0, 3.0, lay.grid_shape)
    old_model = (grid,) + old_pix + (nb_kern.column_rows(grid, *old_pix[3:]),)
    return old_model, extract.SkyModel(grid, pix), lay, old, blk, old_blk


@pytest.mark.parametrize("dtype", DTYPES)
@pytest.mark.parametrize("shape,tile", [((200, 260), 31), ((97, 131), 16), ((40, 50), 5)])
def test_sky_blocks_and_pixel_kernels_match_numba(dtype, shape, tile):
    image = frame(dtype, shape, shape[1])
    old_model, model, lay, old, blk, old_blk = models(shape, tile, 1)
    np.testing.assert_array_equal(model.rows, old_model[7])
    np.testing.assert_array_equal(model.image(), nb_kern.background_image(old_model, *shape))
    means = sky_blocks.block_means(image, 7.5, lay)
    np.testing.assert_array_equal(means, nb_blocks.block_means(image, 7.5, old))
    raw, old_raw = np.empty(lay.grid_shape), np.empty(lay.grid_shape)
    m2, old_m2 = np.empty_like(means), np.empty_like(means)
    sky_blocks.sky_rows(image, 7.5, lay, blk, 0, lay.tiles_down, m2, raw)
    nb_blocks.sky_rows(image, 7.5, old, old_blk, 0, old[0], old_m2, old_raw)
    np.testing.assert_array_equal(m2, old_m2)
    np.testing.assert_array_equal(raw, old_raw)
    grid = old_model[0]
    resid = sky_blocks.residual(means, grid, blk)
    np.testing.assert_array_equal(resid, nb_blocks.residual(means, grid, *old_blk))
    mask = sky_blocks.sources(resid, 1.5)
    np.testing.assert_array_equal(mask, nb_blocks.sources(resid, 1.5))
    for ignore, g, known in ((NO_MASK, NO_GRID, NO_GRID), (mask, grid, NO_GRID),
                             (mask, NO_GRID, raw)):
        np.testing.assert_array_equal(
            sky_blocks.tile_medians(means, ignore, lay, g, blk, known),
            nb_blocks.tile_medians(means, ignore, old[7], old[8], g, old_blk, known))
    for step, smooth in ((1, True), (3, False), (5, True)):
        n = len(range(0, shape[0], step)) * len(range(0, shape[1], step))
        got, want = (np.empty(n), np.empty(n)), (np.empty(n), np.empty(n))
        extract.samples(image, model, step, smooth, 0, len(range(0, shape[0], step)), *got)
        nb_kern.samples(image, old_model, step, smooth, 0, len(range(0, shape[0], step)),
                        *want)
        np.testing.assert_array_equal(got, want)
    threshold = 2.0 * float(np.nanstd(image[np.isfinite(image)]))
    for smooth in (True, False):
        cuts = [0, shape[0] // 3, shape[0] // 3 + 1, shape[0]]
        got = [extract.band_runs(image, model, threshold, smooth, 150.0, a, b)
               for a, b in zip(cuts[:-1], cuts[1:], strict=True)]
        want = [nb_runs.band_runs(image, old_model, threshold, smooth, 150.0, a, b)
                for a, b in zip(cuts[:-1], cuts[1:], strict=True)]
        for g, w in zip(got, want, strict=True):
            np.testing.assert_array_equal(g[0], w[0])
            np.testing.assert_array_equal(g[1], w[1])
        runs = np.concatenate([g[0] for g in got])
        acc = np.concatenate([g[1] for g in got])
        comp = blobs.join_runs(runs, acc.copy())
        np.testing.assert_array_equal(comp, nb_runs.join_runs(runs, acc.copy()))
        box = extract.peak_boxes(image, model, comp[:, 7])
        np.testing.assert_array_equal(box, nb_kern.peak_boxes(image, old_model, comp[:, 7]))
        for a, b in zip(blobs.stars(comp, box, 0.9, 3.0, 2, 40, 160),
                        nb_runs.stars(comp, box, 0.9, 3.0, 2, 40, 160), strict=True):
            np.testing.assert_array_equal(a, b)


def test_grid_clean_up_and_medians_match_numba():
    rng = np.random.default_rng(8)
    for trial in range(200):
        shape = (int(rng.integers(1, 9)), int(rng.integers(1, 9)))
        grid = rng.normal(10.0, 1.0, shape).round(trial % 3)
        if trial % 3 == 0:
            grid[rng.random(shape) < 0.2] = 50.0
        if trial % 4 == 0:
            grid[rng.random(shape) < 0.3] = np.nan
        if trial % 25 == 0:
            grid[:] = np.nan
        for average in (True, False):
            np.testing.assert_array_equal(sky_grid.clean_grid(grid, average, -3.0),
                                          nb_grid.clean_grid(grid, average, -3.0))
    for n in (1, 2, 9, 33, 128, 129, 1000, 1025, 30000):
        for trial in range(20):
            v = rng.normal(0, 3, n).round(trial % 3)
            if trial % 4 == 1:
                v[:n // 5] = 1e9
            counts, c2 = np.empty(256, np.int64), np.empty(256, np.int64)
            assert sky_grid.middle(v.copy(), n, counts) == nb_sky.middle(v.copy(), n, c2)
            assert sky_grid.median(v) == nb_sky.median_of(v)
            assert sky_grid.mad_sigma(v, 1.4826) == nb_sky.mad_sigma(v, 1.4826)


def test_real_frame_kernels_match_numba():
    from pathlib import Path
    image = read_image(Path(__file__).parent / "data" / "realsky_azi45.png")
    old_model, model, lay, old, blk, old_blk = models(image.shape, 31, 2)
    np.testing.assert_array_equal(sky_blocks.block_means(image, 0.0, lay),
                                  nb_blocks.block_means(image, 0.0, old))
    a = extract.band_runs(image, model, 20.0, True, 250.0, 0, image.shape[0])
    b = nb_runs.band_runs(image, old_model, 20.0, True, 250.0, 0, image.shape[0])
    np.testing.assert_array_equal(a[1], b[1])


def test_render_parse_predict_match_numba():
    rng = np.random.default_rng(3)
    for dt in (np.float32, np.float64):
        lam = rng.exponential(200.0, 5000).astype(dt)
        lam[:50] = 2000.0
        u = rng.random(lam.shape)
        e1, e2 = np.empty(lam.shape, np.float32), np.empty(lam.shape, np.float32)
        render.shot_noise(lam, u, e1)
        nb_render.shot_noise(lam, u, e2)
        np.testing.assert_array_equal(e1, e2)
        normal = rng.standard_normal(lam.shape, dtype=np.float32)
        where = rng.permutation(lam.size)
        o1, o2 = np.zeros(lam.size, np.uint16), np.zeros(lam.size, np.uint16)
        chain = (3e4, 10.0, 1.7, 100.0, 4095.0)
        render.readout(e1, normal, render.Readout(*chain), o1, where)
        nb_render.readout(e2, normal, *chain, o2, where)
        np.testing.assert_array_equal(o1, o2)
        flat = np.where(rng.random(20000) < 0.9, 40.0, 60.0).astype(dt)
        from startrack import render_noise
        cdf, guide, a0 = render_noise.adu_table(40.0, *chain)
        s1 = rng.integers(1, 2**63, size=4, dtype=np.int64).astype(np.uint64)
        s2 = s1.copy()
        x1, x2 = np.empty(flat.size, np.int64), np.empty(flat.size, np.int64)
        o3, o4 = np.zeros(flat.size, np.uint16), np.zeros(flat.size, np.uint16)
        n1 = render.sky_pixels(flat, 0, flat.size, render.SkyTable(40.0, cdf, guide, a0), s1,
                               o3, x1)
        n2 = nb_render.sky_pixels(flat, 0, flat.size, dt(40.0), s2, cdf, guide, a0, o4, x2)
        assert n1 == n2
        np.testing.assert_array_equal(o3, o4)
        np.testing.assert_array_equal(s1, s2)
    text = [" 12.345", "-0.5   ", "       ", "+7", "1e5", "123456789012345.6", "3.1.4"]
    for field in text:
        raw = np.frombuffer(f"{field:<20}\n{'2.5':<20}\n".encode(), np.uint8).reshape(2, 21)
        a, ok_a = parse.decimal_column(raw[:, :20], 0, 20)
        b, ok_b = nb_parse.decimal_column(raw[:, :20], 0, 20)
        assert ok_a == ok_b
        if ok_a:
            np.testing.assert_array_equal(a, b)
        np.testing.assert_array_equal(parse.blank_rows(raw[:, :20]),
                                      nb_parse.blank_rows(raw[:, :20]))
    motion = predict.Motion(1e-3, 0.1, 1e-4)
    for _ in range(300):
        v = rng.normal(0, 0.02, 3)
        ra, rb = predict.rotation_exp(v), predict.rotation_exp(rng.normal(0, 0.02, 3))
        np.testing.assert_array_equal(ra, nb_pred.rotation_exp(v))
        np.testing.assert_array_equal(predict.rotation_log(ra), nb_pred.rotation_log(ra))
        for gap, steps in ((0, 1), (1, 1), (3, 2)):
            m1, s1_ = predict.predict_attitude(ra, rb, gap, steps, 1e-5, 2e-5, motion)
            m2, s2_ = nb_pred.predict_attitude(ra, rb, gap, steps, 1e-5, 2e-5, 1e-3, 0.1, 1e-4)
            np.testing.assert_array_equal(m1, m2)
            assert s1_ == s2_
