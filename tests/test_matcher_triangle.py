"""The planar-triangle matcher: vertex mapping and the mirror, the pivot joins, the
Hipparcos pattern-star cap (the contract every matcher meets is in
tests/test_matcher_contract.py)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from synth import frames, prepared_matcher

from startrack.matchers import MatcherConfig, get_matcher
from startrack.matchers.planar_triangle import map_vertices
from startrack.matching.triples import brightness_triples
from startrack.types import MatchDiagnostics

METHOD = "triangle"


@pytest.fixture(scope="module")
def matcher(random_db):
    return prepared_matcher(METHOD, random_db)


def test_brightness_triples_cover_every_triple_brightest_first():
    triples = brightness_triples(6)
    assert sorted(triples) == list(itertools.combinations(range(6), 3))
    assert triples[:4] == [(0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3)]


def test_map_vertices_finds_the_order_and_refuses_the_mirror():
    rng = np.random.default_rng(2)
    tri = rng.normal([0, 0, 1], 0.1, size=(3, 3))
    tri /= np.linalg.norm(tri, axis=1, keepdims=True)
    perm = [2, 0, 1]
    cat = tri[perm][None]  # catalog order: observed vertex perm[m] is catalog vertex m
    cand, p = map_vertices(tri, cat, 1e-9, check_mirror=True)
    assert cand.tolist() == [0]
    assert cat[0][list(list(itertools.permutations(range(3)))[p[0]])].tolist() == tri.tolist()
    mirror = tri * np.array([1, -1, 1])  # a reflection keeps every side
    assert len(map_vertices(mirror, cat, 1e-9, check_mirror=True)[0]) == 0
    assert len(map_vertices(mirror, cat, 1e-9, check_mirror=False)[0]) >= 1


@pytest.mark.slow
def test_real_sky_table_caps_pattern_stars(hip_db):
    """Hipparcos needs the pattern-star cap (the brightest stars of a frame are in it);
    building the table takes seconds, hence slow."""
    prepared_matcher(METHOD, hip_db)
    assert hip_db.triangles.max_per_region is not None


def test_wide_tolerance_forces_pivots(random_db):
    """With 40-sigma windows one triangle matches many catalog triangles; pivoting on
    triangles that share two stars narrows them down to the right one."""
    m = get_matcher(METHOD)(random_db, MatcherConfig(tolerance_sigma=40.0))
    frame = next(frames(random_db.catalog, random_db.camera, 5, seed=71, noise_px=0.3))
    diag = MatchDiagnostics()
    first = next(iter(m.hypotheses(frame.obs, diag)))
    assert diag.pivots >= 1 and len(first.obs_index) >= 4
    assert np.all(frame.truth_rows[first.obs_index] == first.cat_index)
