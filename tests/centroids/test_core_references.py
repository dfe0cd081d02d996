"""The compiled centroider, renderer-noise and prediction kernels held to plain numpy (or
pure-Python) references of the same arithmetic, to the last bit; and the paths that use
them load no JIT compiler."""

import warnings

import numpy as np
import pytest
from waiting import run_python

from startrack._core.centroids import background_blocks as sky_blocks
from startrack._core.centroids import blobs, extract
from startrack._core.simulate import render
from startrack._core.tracking import prediction as predict
from startrack.centroids._extract import _geometry, _native

MASK64 = (1 << 64) - 1


def norm3(v):
    """|v| with the squares summed in extended precision (x87), as BLAS's dnrm2."""
    wide = np.asarray(v, np.longdouble)
    return float(np.sqrt(wide[0] * wide[0] + wide[1] * wide[1] + wide[2] * wide[2]))


def rodrigues(v):
    angle = norm3(v)
    if angle < 1e-15:
        return np.eye(3)
    k = v / angle
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    kk = np.array([[kx[i, 0] * kx[0, j] + kx[i, 1] * kx[1, j] + kx[i, 2] * kx[2, j]
                    for j in range(3)] for i in range(3)])
    return (np.eye(3) + np.sin(angle) * kx) + (1.0 - np.cos(angle)) * kk


def test_rotation_exp_log_and_prediction_match_numpy_bit_for_bit():
    rng = np.random.default_rng(1)
    motion = predict.Motion(1e-3, 0.1, 1e-4)
    for _ in range(200):
        v = rng.normal(0.0, 0.02, 3)
        m = predict.rotation_exp(v)
        np.testing.assert_array_equal(m, rodrigues(v))
        angle = np.arccos(min(1.0, max(-1.0, (m[0, 0] + m[1, 1] + m[2, 2] - 1.0) / 2.0)))
        axis = np.array([m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1]])
        np.testing.assert_array_equal(predict.rotation_log(m),
                                      axis * (angle / (2.0 * np.sin(angle))))
        other = predict.rotation_exp(rng.normal(0.0, 0.02, 3))
        rate = predict.rotation_log(np.array([[sum(m[k, i] * other[k, j] for k in range(3))
                                               for j in range(3)] for i in range(3)])) / 2
        got, sigma = predict.predict_attitude(m, other, 2, 3, 1e-5, 2e-5, motion)
        step = rodrigues(rate * 3)
        want = np.array([[other[i, 0] * step[0, j] + other[i, 1] * step[1, j]
                          + other[i, 2] * step[2, j] for j in range(3)] for i in range(3)])
        np.testing.assert_array_equal(got, want)
        assert sigma == 2e-5 + 3 * (np.hypot(1e-5, 2e-5) / 2 + 0.1 * norm3(rate) + 1e-4)
    _, sigma = predict.predict_attitude(m, m, 0, 4, 1e-5, 2e-5, motion)
    assert sigma == 2e-5 + 4 * 1e-3  # no rate yet


def test_readout_and_shot_noise_match_references():
    rng = np.random.default_rng(2)
    lam = np.r_[rng.exponential(20.0, 3000), 59.9, 60.0, 999.0, 1000.0, 0.0, -1.0]
    uniform = rng.random(lam.size)
    got = np.empty(lam.size, np.float32)
    render.shot_noise(lam, uniform, got)
    for i, (m, u) in enumerate(zip(lam, uniform, strict=True)):
        m = max(m, 0.0)
        if m >= 60.0:
            assert got[i] == (-2.0 if m >= 1000.0 else -1.0)
            continue
        k, p = 0, np.exp(-m)
        cdf = p
        while cdf < u and k < 10_000:
            k += 1
            p *= m / k
            cdf += p
            if p == 0.0 and k > m:
                break
        assert got[i] == k, i
    electrons = rng.uniform(0, 4e4, 5000).astype(np.float32)
    normal = rng.standard_normal(5000, dtype=np.float32)
    where = rng.permutation(5000)
    out = np.zeros(5000, np.uint16)
    render.readout(electrons, normal, render.Readout(3e4, 10.0, 1.7, 100.0, 4095.0), out,
                   where)
    e = np.minimum(electrons.astype(np.float64), 3e4) + 10.0 * normal.astype(np.float64)
    want = np.clip(np.rint(e / 1.7 + 100.0), 0.0, 4095.0).astype(np.uint16)
    np.testing.assert_array_equal(out[where], want)


def test_sky_pixels_follow_xoshiro256_plus_and_the_guide_table():
    rng = np.random.default_rng(3)
    expected = np.where(rng.random(3000) < 0.8, 40.0, 41.0).astype(np.float32)
    cdf = np.r_[np.cumsum(np.full(30, 1 / 30))[:-1], np.inf]
    guide = np.searchsorted(cdf, np.arange(64) / 64, side="right").astype(np.int64)
    state = rng.integers(1, 2**63, size=4, dtype=np.int64).astype(np.uint64)
    s = [int(x) for x in state]
    out, others = np.zeros(3000, np.uint16), np.empty(3000, np.int64)
    n = render.sky_pixels(expected, 0, 3000, render.SkyTable(40.0, cdf, guide, 7), state, out,
                          others)
    np.testing.assert_array_equal(others[:n], np.flatnonzero(expected != 40.0))
    for i in np.flatnonzero(expected == 40.0):
        u = ((s[0] + s[3]) & MASK64) >> 11
        u = float(u) * 2.0**-53
        t = (s[1] << 17) & MASK64
        s[2] ^= s[0]
        s[3] ^= s[1]
        s[1] ^= s[2]
        s[0] ^= s[3]
        s[2] ^= t
        s[3] = ((s[3] << 45) | (s[3] >> 19)) & MASK64
        a = guide[int(u * 64)]
        while cdf[a] <= u:
            a += 1
        assert out[i] == 7 + a
    assert [int(x) for x in state] == s


@pytest.fixture(scope="module")
def frame_and_model():
    rng = np.random.default_rng(4)
    image = rng.normal(100.0, 4.0, (90, 130)).astype(np.float32)
    image[rng.integers(0, 90, 40), rng.integers(0, 130, 40)] += 400.0
    image[10, 20], image[50:53, 60] = np.nan, np.inf
    lay, pixel_w, _ = _geometry(image.shape, 31)
    grid = rng.normal(100.0, 2.0, lay.grid_shape)
    return _native(image), extract.SkyModel(grid, pixel_w)


def reference_residual(image, model):
    w = model.weights
    rows = model.rows
    t = w.row_t[:, None]
    bg = rows[w.row_lo] * (1.0 - t) + rows[w.row_hi] * t
    image = image.astype(np.float64)
    return np.where(np.isfinite(image), image - bg, 0.0), bg


def test_sky_model_and_noise_samples_match_numpy(frame_and_model):
    image, model = frame_and_model
    res, bg = reference_residual(image, model)
    np.testing.assert_array_equal(model.image(), bg.astype(np.float32))
    v = np.pad(res, ((1, 1), (0, 0)), mode="reflect")
    v = 0.25 * v[:-2] + 0.5 * v[1:-1] + 0.25 * v[2:]
    h = np.pad(v, ((0, 0), (1, 1)), mode="reflect")
    det = 0.25 * h[:, :-2] + 0.5 * h[:, 1:-1] + 0.25 * h[:, 2:]
    for step in (1, 2, 7):
        rows = len(range(0, 90, step))
        got = np.empty(rows * len(range(0, 130, step))), np.empty(rows * len(range(0, 130, step)))
        extract.samples(image, model, step, True, 0, rows, *got)
        np.testing.assert_array_equal(got[0], res[::step, ::step].ravel())
        np.testing.assert_array_equal(got[1], det[::step, ::step].ravel())


def test_peak_boxes_and_stars_match_numpy(frame_and_model):
    image, model = frame_and_model
    res, _ = reference_residual(image, model)
    runs, acc = extract.band_runs(image, model, 30.0, False, 450.0, 0, image.shape[0])
    comp = blobs.join_runs(runs, acc)
    peak_at = comp[:, extract.COLUMNS["peak_at"]]
    boxes = extract.peak_boxes(image, model, peak_at)
    for at, box in zip(peak_at.astype(int), boxes, strict=True):
        r, c = divmod(at, image.shape[1])
        want = 0.0
        for rr in np.clip(np.arange(r - 1, r + 2), 0, image.shape[0] - 1):
            for cc in np.clip(np.arange(c - 1, c + 2), 0, image.shape[1] - 1):
                want += res[rr, cc]
        assert box == want
    col = extract.COLUMNS
    found = blobs.stars(comp, boxes, 0.9, 5.0, 1, 3, 6)
    area, sat = comp[:, col["area"]], comp[:, col["sat"]] > 0
    hot = (comp[:, col["peak"]] > 0.9 * boxes) | (boxes - comp[:, col["peak"]] < 5.0)
    keep = ((area >= 1) & (area <= np.where(sat, 6, 3)) & ~hot & (comp[:, col["sw"]] > 0)
            & (comp[:, col["flux"]] > 0))
    assert 0 < keep.sum() < len(comp)
    np.testing.assert_array_equal(found["x"], comp[keep, col["swx"]] / comp[keep, col["sw"]])
    np.testing.assert_array_equal(found["y"], comp[keep, col["swy"]] / comp[keep, col["sw"]])
    np.testing.assert_array_equal(found["flux"], comp[keep, col["flux"]])
    np.testing.assert_array_equal(found["saturated"], sat[keep])
    np.testing.assert_array_equal(found["area"], area[keep].astype(np.int64))


def test_layout_centres_the_blocks_in_the_tiles():
    lay = sky_blocks.Layout(200, 260, 31)
    assert (lay.tiles_down, lay.tiles_across, lay.tile_h, lay.tile_w) == (6, 8, 33, 32)
    assert (lay.block, lay.blocks_down, lay.blocks_across) == (4, 8, 8)
    # (200 - 6 * 33) // 2 + (33 - 8 * 4) // 2 and (260 - 8 * 32) // 2 + 0
    assert (lay.first_row, lay.first_col) == (1, 2)
    assert lay.means_shape == (48, 64) and lay.grid_shape == (6, 8)
    assert sky_blocks.Layout(40, 50, 5).block == 1  # tiles under two blocks across


def test_extraction_rendering_and_prediction_load_no_jit_compiler():
    code = ("import sys, numpy as np\n"
            "from startrack.centroids import extract_centroids\n"
            "from startrack.simulate._render import digitise\n"
            "from startrack.simulate._sensor import SensorModel\n"
            "from startrack._core.sky import parse\n"
            "from startrack._core.tracking import prediction as predict\n"
            "img = digitise(np.full((64, 80), 50.0), SensorModel(), np.random.default_rng(0))\n"
            "extract_centroids(img)\n"
            "predict.rotation_exp(np.array([0.0, 0.0, 0.1]))\n"
            "print('numba' in sys.modules)\n")
    assert run_python(code).strip() == "False"


def reference_clean_grid(grid, average, fallback):
    """The tile grid's clean-up in numpy: spikes (beyond 3 MAD sigmas of the deviations
    from the 3 x 3 nan-median) and NaN tiles replaced by that median, then a 3 x 3 mean;
    NaN left over takes the grid's nan-median, or ``fallback``."""
    grid = grid.copy()
    n_r, n_c = grid.shape
    if n_r >= 3 and n_c >= 3:
        p = np.pad(grid, 1, mode="reflect", reflect_type="odd")
        windows = np.lib.stride_tricks.sliding_window_view(p, (3, 3))
        with warnings.catch_warnings():  # an all-NaN window's median is NaN
            warnings.simplefilter("ignore", RuntimeWarning)
            local = np.nanmedian(windows, axis=(2, 3))
        deviation = np.abs(grid - local)
        if np.isnan(deviation).all():
            grid = local
        else:
            spread = 1.4826 * np.nanmedian(deviation)
            grid = np.where(np.isnan(grid) | (deviation > 3.0 * spread), local, grid)
        if average and not np.isnan(grid).any():
            p = np.pad(grid, 1, mode="reflect", reflect_type="odd")
            grid = np.lib.stride_tricks.sliding_window_view(p, (3, 3)).sum(axis=(2, 3)) / 9.0
    if np.isnan(grid).any():
        value = np.nanmedian(grid) if not np.isnan(grid).all() else fallback
        grid = np.where(np.isnan(grid), value, grid)
    return grid


def test_grid_clean_up_matches_numpy():
    from startrack._core.centroids.background_grid import clean_grid

    rng = np.random.default_rng(8)
    for trial in range(150):
        shape = (int(rng.integers(1, 9)), int(rng.integers(1, 9)))
        grid = rng.normal(10.0, 1.0, shape) + 0.25 * np.arange(shape[1])
        if trial % 3 == 0:
            grid[rng.random(shape) < 0.2] = 50.0  # bright stars
        if trial % 4 == 0:
            grid[rng.random(shape) < 0.3] = np.nan
        if trial % 25 == 0:
            grid[:] = np.nan
        for average in (True, False):
            np.testing.assert_allclose(clean_grid(grid, average, -3.0),
                                       reference_clean_grid(grid, average, -3.0),
                                       rtol=1e-13, atol=0)
