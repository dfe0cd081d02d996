"""Quad patterns where stars are sparse, the sorted-ratio first test, a nominal-FOV range."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from startrack.camera import Camera, stars_in_view
from startrack.database import _quads as Q
from startrack.matchers._quad import match_patterns
from startrack.sky import SkySpec, load_sky
from startrack.solver._fov_search import BlindSolver


def _cluster(n: int, spread: float, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    v = rng.normal([0, 0, 1.0 / spread], 1.0, (n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _brute(v: np.ndarray, min_rad: float, max_rad: float, k: int, max_higher: int) -> set:
    """The rule of :func:`Q.all_quads`, star by star."""
    angle = np.arccos(np.clip(v @ v.T, -1.0, 1.0))
    found = set()
    for a in range(len(v)):
        kth = np.sort(angle[a])[min(k, len(v) - 1)]
        radius = min(max(kth, min_rad), max_rad)
        edge = min(2 * radius, max_rad) if radius > min_rad else radius
        near = [b for b in range(a + 1, len(v)) if angle[a, b] <= radius * (1 + 1e-9)]
        cap = max(k, max_higher) if radius > min_rad else max_higher
        for b, c, d in itertools.combinations(near[:cap], 3):
            if max(angle[b, c], angle[b, d], angle[c, d]) <= edge:
                found.add((a, b, c, d))
    return found


@pytest.mark.parametrize("seed", [3, 4])
def test_sparse_stars_make_patterns_with_their_nearest(seed):
    v = _cluster(30, 0.02, seed)
    min_rad, max_rad = 0.004, 0.06  # a few stars within min_rad: the sparse reach decides
    assert len(Q.all_quads(v, min_rad)) < len(Q.all_quads(v, min_rad, max_rad))
    found = {tuple(q) for q in Q.all_quads(v, min_rad, max_rad).tolist()}
    assert found == _brute(v, min_rad, max_rad, Q.K_NEAREST, Q.MAX_HIGHER)
    radii, _ = Q.pattern_radii(v, min_rad, max_rad)
    assert np.all((radii >= min_rad) & (radii <= max_rad)) and np.any(radii > min_rad)


def test_dense_stars_keep_the_level_pattern_size():
    v = _cluster(200, 0.002, 5)
    radii, rows = Q.pattern_radii(v, 0.01, 0.05)
    assert np.all(radii == 0.01) and np.all(rows == len(v))


def test_the_sorted_ratio_test_keeps_the_true_pattern():
    """An observed pattern (the catalog's, rotated and scaled by the lookup's slack) is
    found with its catalog rows, after the uint8 ratio test."""
    sky = load_sky(SkySpec(kind="random", n_stars=3000, seed=2))
    level = Q.QuadLevel(16.0, Q.build_level_arrays(sky.vectors, 16.0))
    assert level.ratios.dtype == np.uint8 and level.ratios.shape == (len(level), 5)
    camera = Camera.from_fov(1024, 768, 16.0)
    rot = Rotation.from_euler("xyz", [10, 50, 30], degrees=True)
    rows, x, y = stars_in_view(sky, camera, rot)
    obs = camera.pixel_to_vector(x, y)
    obs_q, cat_q, scale, error = match_patterns(obs, level, sky.vectors, 1.05)
    assert len(obs_q) > 0 and np.all(error <= 0.012)
    right = np.all(rows[obs_q] == cat_q, axis=1)
    assert right.any()
    assert np.allclose(scale[right], 1.0, atol=1e-3)


@pytest.mark.parametrize("told, solved", [(1.04, True), (0.96, True), (1.3, False)])
def test_a_nominal_camera_limits_the_search_to_its_tolerance(told, solved):
    sky = SkySpec(kind="random")
    blind = BlindSolver(load_sky(sky), sky, 0.5, fov_range=(14.0, 34.0))
    true = Camera.from_fov(1024, 1024, 20.0)
    rot = Rotation.from_euler("xyz", [20, -35, 70], degrees=True)
    _, x, y = stars_in_view(blind.catalog, true, rot)
    nominal = Camera.from_fov(1024, 1024, 20.0 * told)
    result = blind.solve(x, y, (1024, 1024), camera=nominal, tolerance=0.1)
    assert result.solution.solved == solved
    if solved:
        assert result.camera.fov_deg == pytest.approx(20.0, abs=0.02)
        b = result.solution.rotation.apply([0, 0, 1.0])
        assert math.degrees(math.acos(min(1.0, b @ rot.apply([0, 0, 1.0])))) < 0.02
