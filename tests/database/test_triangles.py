"""Planar-triangle features, their propagated noise, and the catalog triangle table."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from startrack.camera import Camera
from startrack.database import StarDatabase
from startrack.database._triangles import (
    auto_max_per_region,
    brighter_neighbours,
    feature_sigmas,
    triangle_features,
)
from startrack.sky import Catalog, random_sky


def _on_circle(r: float, phis_deg) -> list[np.ndarray]:
    """Unit vectors on the small circle of (chord) radius r around +z."""
    phis = np.radians(phis_deg)
    h = math.sqrt(1 - r * r)
    return [np.array([r * math.cos(p), r * math.sin(p), h]) for p in phis]


def test_equilateral_triangle():
    r = 0.1
    area, polar = triangle_features(*_on_circle(r, [0, 120, 240]))
    side = r * math.sqrt(3)
    assert area == pytest.approx(math.sqrt(3) / 4 * side**2, rel=1e-12)
    assert polar == pytest.approx(area * 3 * side**2 / 36, rel=1e-12)


def test_right_triangle_and_vertex_order_symmetry():
    # Thales: a diameter of the circle as one side puts the right angle at the third vertex.
    r = 0.2
    v1, v2, v3 = _on_circle(r, [0, 180, 60])
    area, polar = triangle_features(v1, v2, v3)
    assert area == pytest.approx(r * r * math.sqrt(3) / 2, rel=1e-12)
    assert polar == pytest.approx(area * 8 * r * r / 36, rel=1e-12)
    for perm in itertools.permutations([v1, v2, v3]):
        assert np.allclose(triangle_features(*perm), (area, polar), rtol=1e-12)


def test_area_equals_heron_on_random_triangles():
    rng = np.random.default_rng(3)
    v = rng.normal(size=(3, 500, 3))
    v /= np.linalg.norm(v, axis=-1, keepdims=True)
    area, _ = triangle_features(v[0], v[1], v[2])
    a, b, c = (np.linalg.norm(v[i] - v[j], axis=-1) for i, j in ((0, 1), (1, 2), (0, 2)))
    s = (a + b + c) / 2
    heron = np.sqrt(np.maximum(s * (s - a) * (s - b) * (s - c), 0))
    assert np.allclose(area, heron, rtol=1e-8, atol=1e-12)


@pytest.mark.parametrize("phis", [[0, 110, 230], [0, 20, 185]])  # fat and thin triangles
def test_propagated_sigmas_agree_with_monte_carlo(phis):
    rng = np.random.default_rng(7)
    verts = _on_circle(0.12, phis)
    sigma = 1e-4
    n = 4000
    noisy = []
    for v in verts:
        # Isotropic 3-D noise projected on the tangent plane: sigma per tangent axis.
        e = rng.normal(0, sigma, size=(n, 3))
        e -= np.outer(e @ v, v)
        p = v + e
        noisy.append(p / np.linalg.norm(p, axis=1, keepdims=True))
    area_mc, polar_mc = triangle_features(*noisy)
    s_area, s_polar = feature_sigmas(*verts, sigma)
    assert float(s_area) == pytest.approx(np.std(area_mc), rel=0.2)
    assert float(s_polar) == pytest.approx(np.std(polar_mc), rel=0.2)
    # Vectorised: a batch gives the same answer as one triangle at a time.
    batch = feature_sigmas(*[np.stack([v, v]) for v in verts], sigma)
    assert np.allclose(batch[0], s_area) and np.allclose(batch[1], s_polar)


def _tiny_catalog() -> Catalog:
    ra = [0, 5, 10, 3, 40, 44, 8, 90, 2]
    dec = [0, 1, -2, 6, 0, 3, 12, 0, -9]
    return Catalog(ids=np.arange(len(ra)), ra_deg=np.array(ra, float),
                   dec_deg=np.array(dec, float), mag=np.linspace(1, 5, len(ra)))


def _brute_force(vectors: np.ndarray, max_angle: float, rows=None) -> set[tuple[int, ...]]:
    rows = range(len(vectors)) if rows is None else rows
    ang = np.arccos(np.clip(vectors @ vectors.T, -1, 1))
    return {t for t in itertools.combinations(sorted(rows), 3)
            if max(ang[t[0], t[1]], ang[t[1], t[2]], ang[t[0], t[2]]) <= max_angle}


def test_table_holds_exactly_the_triangles_within_the_limit():
    db = StarDatabase(_tiny_catalog(), Camera.from_fov(512, 512, 12.0))
    table = db.triangle_table(max_per_region=None)
    want = _brute_force(db.vectors, db.max_angle_rad)
    got = {tuple(sorted(t)) for t in table.rows.tolist()}
    assert got == want
    assert 0 < len(want) < math.comb(len(db.vectors), 3)  # the limit did exclude some
    assert np.all(np.diff(table.area) >= 0)
    v = db.vectors[table.rows]
    area, polar = triangle_features(v[:, 0], v[:, 1], v[:, 2])
    assert np.allclose(area, table.area) and np.allclose(polar, table.polar)
    # Canonical order: vertex 0 faces the shortest side, vertex 2 the longest.
    opposite = np.column_stack([np.linalg.norm(v[:, 1] - v[:, 2], axis=1),
                                np.linalg.norm(v[:, 0] - v[:, 2], axis=1),
                                np.linalg.norm(v[:, 0] - v[:, 1], axis=1)])
    assert np.all(np.diff(opposite, axis=1) >= 0)


@pytest.fixture(scope="module")
def small_db() -> StarDatabase:
    return StarDatabase(random_sky(150, seed=4), Camera.from_fov(1024, 1024, 40.0))


def test_table_on_a_random_sky_matches_brute_force(small_db):
    table = small_db.triangle_table(max_per_region=None)
    want = _brute_force(small_db.vectors, small_db.max_angle_rad)
    assert table.max_per_region is None
    assert len(table) == len(want)
    assert {tuple(sorted(t)) for t in table.rows.tolist()} == want


def test_pattern_star_cap_keeps_only_regionally_bright_stars(small_db):
    radius = math.radians(20.0)
    brighter = brighter_neighbours(small_db.vectors, radius)
    ang = np.arccos(np.clip(small_db.vectors @ small_db.vectors.T, -1, 1))
    want = [(np.flatnonzero(ang[r, :r] <= radius)).size for r in range(len(ang))]
    assert brighter.tolist() == want
    table = small_db.triangle_table(max_per_region=3, region_radius_deg=20.0)
    pattern = np.flatnonzero(brighter < 3)
    assert table.max_per_region == 3 and table.pattern.tolist() == pattern.tolist()
    got = {tuple(sorted(t)) for t in table.rows.tolist()}
    assert got == _brute_force(small_db.vectors, small_db.max_angle_rad, pattern)


def test_auto_cap_fits_the_budget(small_db):
    pairs = small_db.pairs
    brighter = brighter_neighbours(small_db.vectors, math.radians(20.0))
    assert auto_max_per_region(brighter, pairs.i, pairs.j, budget=10**9) is None
    full = len(small_db.triangle_table(max_per_region=None))
    cap = auto_max_per_region(brighter, pairs.i, pairs.j, budget=full // 4)
    assert cap is not None and cap >= 1
    capped = small_db.triangle_table(max_per_region=cap, region_radius_deg=20.0)
    assert len(capped) < full // 2  # the estimate is rough; the cut is not


def test_queries_match_a_brute_force_filter(small_db):
    table = small_db.triangle_table(max_per_region=None)
    rng = np.random.default_rng(9)
    for _ in range(50):
        a0, j0 = rng.choice(table.area), rng.choice(table.polar)
        da, dj = rng.uniform(0, 0.01), rng.uniform(0, 1e-3)
        idx, n_area = table.query(a0 - da, a0 + da, j0 - dj, j0 + dj)
        in_area = (table.area >= a0 - da) & (table.area <= a0 + da)
        want = np.flatnonzero(in_area & (table.polar >= j0 - dj) & (table.polar <= j0 + dj))
        assert n_area == in_area.sum()
        assert idx.tolist() == want.tolist()


def test_compiled_enumeration_equals_brute_force():
    from startrack._core.database.builds import triangles_of_pairs

    rng = np.random.default_rng(3)
    n = 25
    pairs = {(a, b) for a, b in rng.integers(0, n, size=(150, 2)).tolist() if a < b}
    lo, hi = (np.array(c, np.int64) for c in zip(*sorted(pairs), strict=True))
    v = rng.normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    rows, area, _ = triangles_of_pairs(n, lo, hi, v)
    want = [t for t in itertools.combinations(range(n), 3)
            if {(t[0], t[1]), (t[1], t[2]), (t[0], t[2])} <= pairs]
    assert sorted(tuple(sorted(r)) for r in rows.tolist()) == want
    for r in rows:  # vertex 0 faces the shortest side, vertex 2 the longest
        opposite = [np.linalg.norm(v[r[1]] - v[r[2]]), np.linalg.norm(v[r[0]] - v[r[2]]),
                    np.linalg.norm(v[r[0]] - v[r[1]])]
        assert opposite[0] <= opposite[1] <= opposite[2]
    np.testing.assert_allclose(area, triangle_features(v[rows[:, 0]], v[rows[:, 1]],
                                                       v[rows[:, 2]])[0])


def test_bucket_argsort_is_the_stable_argsort():
    from startrack._core.database.builds import stable_argsort

    rng = np.random.default_rng(12)
    values = np.concatenate([rng.uniform(0, 1, 3000), rng.uniform(0, 1, 20).repeat(5),
                             [0.0, 1.0, 1.0]])
    np.testing.assert_array_equal(stable_argsort(values, 0.0, 1.0),
                                  np.argsort(values, kind="stable"))
    skewed = rng.exponential(1e-3, 5000)
    np.testing.assert_array_equal(stable_argsort(skewed, 0.0, float(skewed.max())),
                                  np.argsort(skewed, kind="stable"))
