"""Centroid extraction on synthetic frames with known truth, and on one real-sky frame."""


import numpy as np
import pytest
from repo_paths import DATA
from scipy.special import erf

from startrack.centroids._extract import CentroidConfig, estimate_background, extract_centroids
from startrack.io import read_image

REAL_SKY = DATA / "realsky_azi45.png"


def add_spot(image, x, y, flux, sigma):
    """Add a pixel-integrated Gaussian spot centred at (x, y) = (column, row)."""
    def edges(n, c):
        e = (np.arange(n + 1) - 0.5 - c) / (np.sqrt(2) * sigma)
        return np.diff(0.5 * erf(e))

    image += flux * np.outer(edges(image.shape[0], y), edges(image.shape[1], x))


def frame(rng, stars, shape=(200, 260), noise=10.0, psf=1.2, sky=1000.0, slope=(6.0, 3.0)):
    """Stars (x, y, flux) on a sky rising by ``slope`` counts/px along (x, y), plus noise."""
    h, w = shape
    rows, cols = np.mgrid[0:h, 0:w]
    image = sky + slope[0] * cols + slope[1] * rows + rng.normal(0.0, noise, shape)
    for x, y, flux in stars:
        add_spot(image, x, y, flux, psf)
    return image


def random_stars(rng, n, shape=(200, 260), flux=(2e4, 2e5), margin=12):
    h, w = shape
    x = rng.uniform(margin, w - 1 - margin, n)
    y = rng.uniform(margin, h - 1 - margin, n)
    f = rng.uniform(*flux, n)
    # keep spots apart so that each is its own component
    keep = np.ones(n, bool)
    for i in range(n):
        d = np.hypot(x[:i] - x[i], y[:i] - y[i])
        keep[i] = not np.any(d[keep[:i]] < 15)
    return np.c_[x, y, f][keep]


def match(found, truth, tol=2.0):
    """Index into ``found`` for each truth star (-1 when none within tol px)."""
    d = np.hypot(found.x[None, :] - truth[:, :1], found.y[None, :] - truth[:, 1:2])
    j = d.argmin(axis=1)
    return np.where(d[np.arange(len(truth)), j] < tol, j, -1)


def test_every_spot_found_with_subpixel_accuracy():
    rng = np.random.default_rng(10)
    truth = random_stars(rng, 25)
    image = frame(rng, truth).astype(np.float32)
    found = extract_centroids(image)
    j = match(found, truth)
    assert np.all(j >= 0)
    assert len(found) == len(truth)  # the gradient produced no false spots
    err = np.hypot(found.x[j] - truth[:, 0], found.y[j] - truth[:, 1])
    assert err.max() < 0.1
    assert np.allclose(found.flux[j], truth[:, 2], rtol=0.05)


def test_brightest_first_in_true_order():
    rng = np.random.default_rng(11)
    truth = random_stars(rng, 12, flux=(5e3, 5e5))
    found = extract_centroids(frame(rng, truth))
    assert np.all(np.diff(found.flux) <= 0)
    j = match(found, truth)
    assert np.all(j >= 0)
    np.testing.assert_array_equal(np.argsort(j), np.argsort(-truth[:, 2]))


def test_hot_pixels_rejected_sharp_star_kept():
    rng = np.random.default_rng(12)
    truth = np.array([[60.3, 50.6, 5e4], [200.0, 150.0, 3e4]])
    image = frame(rng, truth[:1])
    add_spot(image, *truth[1], sigma=0.45)  # sharp, but still spread over its neighbours
    hot = [(30, 170, 200.0), (100, 100, 1000.0), (180, 40, 30000.0)]  # (row, col, counts)
    for r, c, v in hot:
        image[r, c] += v
    found = extract_centroids(image)
    assert np.all(match(found, truth, tol=0.5) >= 0)
    for r, c, _ in hot:
        assert np.all(np.hypot(found.x - c, found.y - r) > 2), (r, c)
    assert len(found) == 2


def test_single_pixel_star_rejected_by_min_area():
    rng = np.random.default_rng(13)
    image = frame(rng, [(80.0, 90.0, 4e4)], slope=(0.0, 0.0))
    image[20:22, 30] += 3000.0  # a two-pixel defect: not peaked, but tiny
    loose = extract_centroids(image, CentroidConfig(smooth=False, min_area=1))
    strict = extract_centroids(image, CentroidConfig(smooth=False, min_area=3))
    assert len(loose) == 2 and len(strict) == 1
    assert abs(strict.x[0] - 80.0) < 0.1


def test_oversized_blob_rejected():
    rng = np.random.default_rng(14)
    truth = np.array([[40.2, 160.7, 4e4]])
    image = frame(rng, truth)
    add_spot(image, 150.0, 90.0, 3e6, sigma=9.0)  # a galaxy/planet-sized glow
    found = extract_centroids(image)
    assert len(found) == 1
    assert np.hypot(found.x[0] - 40.2, found.y[0] - 160.7) < 0.1
    assert not np.any(np.hypot(found.x - 150.0, found.y - 90.0) < 60)  # nor its halo
    allowed = extract_centroids(image, CentroidConfig(max_area=100_000))
    assert np.any(np.hypot(allowed.x - 150.0, allowed.y - 90.0) < 3.0)


def test_saturated_spot_flagged_16bit():
    rng = np.random.default_rng(15)
    truth = np.array([[70.4, 60.2, 5e6], [180.6, 130.3, 4e4]])
    image = np.clip(np.rint(frame(rng, truth)), 0, 65535).astype(np.uint16)
    assert (image == 65535).sum() > 3
    found = extract_centroids(image)
    j = match(found, truth, tol=0.3)
    assert np.all(j >= 0)
    assert found.saturated[j].tolist() == [True, False]
    assert j[0] == 0  # still the brightest
    assert len(found) == 2


def test_8bit_frame():
    rng = np.random.default_rng(16)
    truth = random_stars(rng, 10, flux=(800, 1500))  # peaks ~90-170 counts
    image = frame(rng, truth, noise=2.0, sky=20.0, slope=(0.08, 0.05))  # sky 20-50 counts
    image8 = np.clip(np.rint(image), 0, 255).astype(np.uint8)
    found = extract_centroids(image8)
    j = match(found, truth)
    assert np.all(j >= 0) and len(found) == len(truth)
    err = np.hypot(found.x[j] - truth[:, 0], found.y[j] - truth[:, 1])
    assert err.max() < 0.1
    assert not found.saturated.any()


def test_saturated_8bit_flag():
    rng = np.random.default_rng(17)
    image = frame(rng, [(100.0, 100.0, 5000.0), (40.0, 150.0, 1000.0)], noise=2.0, sky=20.0,
                  slope=(0.08, 0.05))
    image = np.clip(image, 0, 255)
    found = extract_centroids(np.rint(image).astype(np.uint8))
    assert len(found) == 2 and found.saturated.tolist() == [True, False]
    assert not extract_centroids(image.astype(np.float32)).saturated.any()  # float: no level


def test_noise_only_gives_nothing_and_nan_is_harmless():
    rng = np.random.default_rng(18)
    image = frame(rng, [])
    assert len(extract_centroids(image)) == 0
    image[5:9, 7:12] = np.nan
    add_spot(image, 130.0, 110.0, 3e4, 1.2)
    found = extract_centroids(image)
    assert len(found) == 1 and abs(found.x[0] - 130.0) < 0.1


def test_max_stars_keeps_the_brightest():
    rng = np.random.default_rng(19)
    truth = random_stars(rng, 10)
    image = frame(rng, truth)
    every = extract_centroids(image)
    top = extract_centroids(image, CentroidConfig(max_stars=3))
    assert len(top) == 3
    np.testing.assert_array_equal(top.x, every.x[:3])


def test_background_follows_a_plane_to_the_border():
    rows, cols = np.mgrid[0:100, 0:130]
    plane = (2000.0 + 7.0 * cols - 4.0 * rows).astype(np.float32)
    bg = estimate_background(plane, 31)
    assert np.abs(bg - plane).max() < 0.5


@pytest.mark.parametrize("bad", [dict(k_sigma=0), dict(min_area=5, max_area=4),
                                 dict(background_size=1), dict(hot_pixel_fraction=0)])
def test_bad_config(bad):
    with pytest.raises(ValueError):
        CentroidConfig(**bad)


def test_bad_image_shape():
    with pytest.raises(ValueError, match="2-D"):
        extract_centroids(np.zeros((4, 4, 3)))


def test_real_sky_frame():
    image = read_image(REAL_SKY)
    found = extract_centroids(image)
    # the frame looks into the Milky Way in Cassiopeia: a few hundred stars above 5 sigma
    assert 15 <= len(found) <= 400
    h, w = image.shape
    top = found.brightest(10)
    assert np.all((top.x > 5) & (top.x < w - 6) & (top.y > 5) & (top.y < h - 6))
    assert np.all(top.area >= CentroidConfig().min_area)
    assert np.all(found.area >= CentroidConfig().min_area)
    # the inverted frame has holes where the stars were: no noise or gradient detections
    assert len(extract_centroids((65535 - image).astype(np.uint16))) <= 2


def test_known_subpixel_position_uint16():
    rng = np.random.default_rng(20)
    truth = np.array([[123.37, 88.81, 6e4]])
    image = np.clip(np.rint(frame(rng, truth, noise=5.0)), 0, 65535).astype(np.uint16)
    found = extract_centroids(image)
    assert len(found) == 1
    assert np.hypot(found.x[0] - 123.37, found.y[0] - 88.81) < 0.05


def saturated_plate(rng, size, blob_sigma):
    """A 16-bit plate with faint stars and one huge saturated star (a bloomed blob)."""
    stars = random_stars(rng, 8, shape=(size, size), flux=(2e4, 5e4), margin=100)
    image = frame(rng, stars, shape=(size, size), slope=(0.5, 0.3))
    add_spot(image, size / 2 + 0.3, size / 2 - 0.2, 4e8, blob_sigma)
    return np.clip(np.rint(image), 0, 65535).astype(np.uint16), stars


def test_large_saturated_star_kept_on_a_big_plate():
    rng = np.random.default_rng(21)
    image, stars = saturated_plate(rng, 2048, 7.0)
    found = extract_centroids(image)
    assert found.saturated[0] and found.area[0] > 400  # bigger than the old fixed limit
    assert np.hypot(found.x[0] - 1024.3, found.y[0] - 1023.8) < 0.2  # and the brightest
    assert np.all(match(found, stars) >= 0)
    # explicit limits still apply
    small = extract_centroids(image, CentroidConfig(max_area=400, max_saturated_area=400))
    assert not np.any(np.hypot(small.x - 1024.3, small.y - 1023.8) < 5)
    assert CentroidConfig().area_limits((2048, 2048)) == (1600, 6400)
    assert CentroidConfig().area_limits((100, 100)) == (400, 1600)


def test_vignetted_glow_with_hot_pixels_and_no_stars_gives_nothing():
    rng = np.random.default_rng(22)
    rows, cols = np.mgrid[0:768, 0:1024]
    r2 = ((cols - 512) / 512.0) ** 2 + ((rows - 384) / 512.0) ** 2
    glow = 2000 + 4000 * np.exp(-r2 / 0.6) + 3.0 * cols  # vignetting + sky-glow gradient
    image = glow + rng.normal(0, 40, glow.shape)
    hot = rng.integers(0, [768, 1024], size=(60, 2))
    image[hot[:, 0], hot[:, 1]] += rng.uniform(3000, 30000, 60)
    image = np.clip(np.rint(image), 0, 65535).astype(np.uint16)
    for config in (None, CentroidConfig(fast=True)):
        assert len(extract_centroids(image, config)) == 0


def test_fast_mode_finds_the_bright_stars_as_accurately():
    rng = np.random.default_rng(23)
    truth = random_stars(rng, 20, flux=(3e4, 2e5))
    image = frame(rng, truth)
    fast = extract_centroids(image, CentroidConfig(fast=True))
    j = match(fast, truth)
    assert np.all(j >= 0) and len(fast) == len(truth)
    err = np.hypot(fast.x[j] - truth[:, 0], fast.y[j] - truth[:, 1])
    assert err.max() < 0.1


def test_grid_window_median_matches_nanmedian():
    """The 3 x 3 window medians of the grid clean-up (a median network, or a sort when a
    NaN is in the window): numpy's nanmedian, ties, infinities and NaNs included."""
    from startrack._core.centroids.background_grid import window_median

    rng = np.random.default_rng(3)
    for trial in range(3000):
        # + 0.0: no -0.0, which equals 0.0 in any sort, so either may come out of a tie
        window = np.pad(rng.normal(0, 1, (3, 3)).round(trial % 2) + 0.0, 1)
        inner = window[1:4, 1:4]
        if trial % 4 == 0:
            inner[rng.random((3, 3)) < 0.3] = np.inf
        if trial % 5 == 0:
            inner[rng.random((3, 3)) < 0.2] = -np.inf
        if trial % 7 == 0:
            inner[rng.random((3, 3)) < 0.4] = np.nan
        finite = inner[~np.isnan(inner)]
        want = np.median(finite) if len(finite) else np.nan
        np.testing.assert_equal(window_median(window, 1, 1), want)


@pytest.mark.parametrize("n", [3, 8, 9, 55, 56, 57, 128, 129])
def test_pivot_median_of_a_tile_is_exact(n):
    """Tile-sized arrays (pivots narrow the middle ranks): ties that no pivot splits,
    outliers that throw the interpolation off, the two middle values either side of a
    pivot."""
    from startrack._core.centroids.background_grid import middle

    rng = np.random.default_rng(n)
    counts = np.empty(256, np.int64)
    for trial in range(300):
        values = rng.normal(100.0, 5.0, n).round(trial % 3)
        if trial % 4 == 1:
            values[:n // 3] = 1e9  # bright stars
        if trial % 5 == 2:
            values = np.where(rng.random(n) < 0.5, 7.0, 7.0625)  # quantised block means
        if trial % 7 == 3:
            values[rng.random(n) < 0.6] = 100.0  # a run of ties across the middle
        assert middle(values.copy(), n, counts) == np.median(values), trial


@pytest.mark.parametrize("n", [1, 2, 7, 64, 255, 256, 5000])
def test_histogram_median_is_exact(n):
    from startrack._core.centroids.background_grid import mad_sigma, median

    rng = np.random.default_rng(n)
    outliers = rng.normal(0, 1, n)
    outliers[:min(n, 3)] = [1e12, -1e9, 5e8][:min(n, 3)]  # the rest crowd into a few bins
    for values in (rng.normal(0, 3, n), np.rint(rng.normal(200, 2, n)),
                   np.r_[rng.normal(0, 1, n - n // 3), np.full(n // 3, 6e4)], outliers,
                   np.where(np.arange(n) % 2, 1.0, 2.0), rng.exponential(1.0, n) ** 6):
        assert median(values) == np.median(values)
        want = 1.4826 * np.median(np.abs(values - np.median(values)))
        assert mad_sigma(values, 1.4826) == pytest.approx(want, rel=1e-12, abs=1e-12)
