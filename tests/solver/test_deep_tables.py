"""Deep catalogs' tables within bounded memory: pattern tables built chunk by chunk (the
same table as in one piece), large cache entries mapped rather than read, and the
centroid error a frame's star images allow."""

import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

from startrack.centroids import Centroids, frame_sigma_px
from startrack.centroids._table import DEFAULT_SIGMA_PX, MAX_FRAME_SIGMA_PX, SIGMA_PER_RADIUS
from startrack.database import _quads as Q
from startrack.io import _cache
from startrack.sky import random_sky


def test_patterns_built_in_chunks_are_the_patterns_built_at_once():
    v = random_sky(1500, seed=4).vectors
    whole = Q.all_quads(v, 0.12, 0.3)
    assert len(whole) > 1000
    for chunk in (1, 7, 500, 4096):
        parts = list(Q.quad_chunks(v, 0.12, 0.3, chunk=chunk))
        np.testing.assert_array_equal(np.concatenate(parts), whole)


def test_each_chunks_neighbour_lists_are_its_close_pairs_by_brightness():
    v = random_sky(600, seed=5).vectors
    radius = 0.15
    pairs = cKDTree(v).query_pairs(2 * math.sin(radius / 2), output_type="ndarray")
    rows = slice(100, 250)
    _, sparse = Q.pattern_radii(v, radius, radius, rows=rows)
    indptr, indices = Q._neighbour_lists(v, radius, sparse, rows)
    for a in range(100, 250):
        want = sorted(int(j) for i, j in np.sort(pairs, axis=1) if i == a)
        assert indices[indptr[a - 100]:indptr[a - 99]].tolist() == want


def test_a_level_table_does_not_depend_on_the_build_chunk(monkeypatch):
    v = random_sky(3000, seed=6).vectors
    one = Q.build_level_arrays(v, 11.3)
    monkeypatch.setattr(Q, "BUILD_CHUNK_STARS", 97)
    chunked = Q.build_level_arrays(v, 11.3)
    for key in ("keys", "quads", "ratios"):
        assert chunked[key].dtype == one[key].dtype
        np.testing.assert_array_equal(chunked[key], one[key])


def test_a_large_cache_entry_is_mapped_read_only_and_a_small_one_read(monkeypatch):
    arrays = {"keys": np.arange(50_000, dtype=np.int32),
              "quads": np.arange(200_000, dtype=np.int32).reshape(-1, 4)}
    built = []

    def build():
        built.append(1)
        return arrays

    monkeypatch.setattr(_cache, "MAP_MIN_BYTES", 100_000)
    first = _cache.cached_arrays("maptest", {"n": 1}, build)
    again = _cache.cached_arrays("maptest", {"n": 1}, build)
    assert built == [1]
    assert isinstance(again["keys"], np.memmap) and not again["keys"].flags.writeable
    for key, arr in arrays.items():
        np.testing.assert_array_equal(again[key], arr)
        np.testing.assert_array_equal(first[key], arr)
    monkeypatch.setattr(_cache, "MAP_MIN_BYTES", 1 << 40)
    read = _cache.cached_arrays("maptest", {"n": 1}, build)
    assert not isinstance(read["keys"], np.memmap) and read["keys"].flags.writeable


def test_a_mapped_entry_of_another_key_is_rebuilt(monkeypatch):
    monkeypatch.setattr(_cache, "MAP_MIN_BYTES", 1000)
    arrays = {"a": np.arange(10_000, dtype=np.int64)}
    _cache.cached_arrays("maptest", {"n": 2}, lambda: arrays)
    path = _cache.cache_dir() / f"{_cache.cache_key('maptest', {'n': 2})}.npz"
    other = _cache.cache_dir() / f"{_cache.cache_key('maptest', {'n': 3})}.npz"
    other.write_bytes(path.read_bytes())  # the right size, the wrong entry
    rebuilt = []
    _cache.cached_arrays("maptest", {"n": 3}, lambda: rebuilt.append(1) or arrays)
    assert rebuilt == [1]


def _stars(areas):
    n = len(areas)
    return Centroids(np.arange(n, dtype=float), np.zeros(n), np.arange(n, 0, -1.0),
                     area=np.asarray(areas))


@pytest.mark.parametrize(("areas", "want"), [
    ([9] * 30, DEFAULT_SIGMA_PX),  # compact images: the default
    ([0] * 30, DEFAULT_SIGMA_PX),  # no areas (a centroid list): the default
    ([math.pi * 10.0**2] * 20 + [4] * 100, SIGMA_PER_RADIUS * 10.0),  # the brightest decide
    ([1e6] * 30, MAX_FRAME_SIGMA_PX),
])
def test_the_frames_centroid_error_follows_its_star_images(areas, want):
    assert frame_sigma_px(_stars(areas)) == pytest.approx(want, rel=1e-3)


def _frame(spots, size=200, seed=0):
    """A noisy frame with Gaussian spots (x, y, sigma_x, sigma_y, peak)."""
    yy, xx = np.mgrid[:size, :size]
    image = np.random.default_rng(seed).normal(100.0, 2.0, (size, size))
    for x, y, sx, sy, peak in spots:
        image += peak * np.exp(-0.5 * (((xx - x) / sx) ** 2 + ((yy - y) / sy) ** 2))
    return image


def test_a_spots_elongation_is_the_ratio_of_its_axes():
    from startrack.centroids import CentroidConfig, extract_centroids

    found = extract_centroids(_frame([(50, 50, 1.5, 1.5, 900.0), (140, 120, 4.5, 1.5, 900.0)]),
                              CentroidConfig(shape_cut=False))
    by_x = np.argsort(found.x)
    round_, long_ = found.elongation[by_x]
    assert 0.9 < round_ < 1.15
    assert 2.3 < long_ < 3.3  # 3 for the whole Gaussian; the threshold cuts its tails


def test_spots_far_more_elongated_than_the_frames_stars_are_dropped():
    """A caption's strokes or a trail among round stars go; trailed stars, all alike, stay."""
    from startrack.centroids import CentroidConfig, extract_centroids

    grid = [(30.0 + 60 * i, 90.0 + 50 * j) for i in range(5) for j in range(4)]  # apart
    stars = [(x, y, 1.6, 1.6, 800.0) for x, y in grid]
    streak = (150, 40, 6.0, 1.2, 800.0)
    kept = extract_centroids(_frame(stars + [streak], 300))
    every = extract_centroids(_frame(stars + [streak], 300), CentroidConfig(shape_cut=False))
    assert len(every) == len(kept) + 1
    assert not np.any((np.abs(kept.x - 150) < 3) & (np.abs(kept.y - 40) < 3))
    trailed = [(x, y, 4.0, 1.3, 800.0) for x, y, *_ in stars]
    assert len(extract_centroids(_frame(trailed, 300))) == len(
        extract_centroids(_frame(trailed, 300), CentroidConfig(shape_cut=False)))


def test_a_slow_build_says_what_it_builds_unless_quiet(monkeypatch, capsys):
    import time

    monkeypatch.setattr(_cache, "BUILD_NOTICE_S", 0.05)

    def slow():
        time.sleep(0.5)
        return {"a": np.arange(3)}

    _cache.announce_builds(True)
    try:
        _cache.cached_arrays("slowtest", {"n": 1}, slow)
        assert "building the slowtest table once" in capsys.readouterr().err
        _cache.announce_builds(False)
        _cache.cached_arrays("slowtest", {"n": 2}, slow)
        assert capsys.readouterr().err == ""
    finally:
        _cache.announce_builds(False)


def test_a_cuts_cone_index_is_the_index_built_for_it():
    from startrack.database import ConeIndex

    sky = random_sky(4000, seed=8)
    whole = ConeIndex.build(sky.vectors)
    for n in (1, 37, 2500, 4000):
        cut, built = whole.prefix(n), ConeIndex.build(sky.vectors[:n])
        for name in ("vectors", "order", "ra_sorted", "band_start"):
            np.testing.assert_array_equal(getattr(cut, name), getattr(built, name))
        direction = sky.vectors[n // 2]
        np.testing.assert_array_equal(cut.rows(direction, 0.2), built.rows(direction, 0.2))


def test_a_catalogs_head_is_its_magnitude_cut():
    sky = random_sky(500, seed=9)
    head, cut = sky.head(120), sky.subset(np.arange(120))
    for name in ("ids", "ra_deg", "dec_deg", "mag", "vectors"):
        np.testing.assert_array_equal(getattr(head, name), getattr(cut, name))
    assert head.fingerprint() == cut.fingerprint() == sky.fingerprint(120)


def test_close_stars_merge_greedily_in_brightness_order():
    """Each kept star removes its fainter close partners; a removed star removes none (the
    vectorised fixed point is the greedy loop, on random pair graphs)."""
    from startrack.sky._catalog import kept_in_brightness_order

    rng = np.random.default_rng(11)
    for _ in range(200):
        n = int(rng.integers(2, 50))
        a, b = rng.integers(0, n, 120), rng.integers(0, n, 120)
        a, b = np.minimum(a[a != b], b[a != b]), np.maximum(a[a != b], b[a != b])
        want = np.ones(n, bool)
        for i in np.lexsort((b, a)):
            if want[a[i]]:
                want[b[i]] = False
        np.testing.assert_array_equal(kept_in_brightness_order(a, b, n), want)


def test_too_few_stars_are_answered_without_loading_a_sky(monkeypatch):
    """A blank frame at a narrow FOV once built a deep sky's tables (minutes, GBs) before
    saying "too_few_stars"; now no sky is loaded at all."""
    import startrack
    from startrack.solver import _pipeline

    def no_sky(*_args, **_kwargs):
        raise AssertionError("a sky was loaded for two stars")

    monkeypatch.setattr(_pipeline, "load_sky", no_sky)
    for fov in (0.3, None):
        result = startrack.solve(np.array([[10.0, 20.0, 5.0], [50.0, 60.0, 4.0]]),
                                 fov_deg=fov, size=(1024, 1024))
        assert not result.solved and result.reason == "too_few_stars"
