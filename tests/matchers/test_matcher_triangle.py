"""The planar-triangle matcher: the pivot joins, the Hipparcos pattern-star cap (the vertex
mapping and the mirror are in tests/matchers/test_triangle_search.py, the contract every matcher
meets in tests/matchers/test_matcher_contract.py)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from synth import frames, prepared_matcher

from startrack.match_records import MatchDiagnostics
from startrack.matchers import MatcherConfig, get_matcher
from startrack.matchers._shared.triples import brightness_triples

METHOD = "triangle"


@pytest.fixture(scope="module")
def matcher(random_db):
    return prepared_matcher(METHOD, random_db)


def test_brightness_triples_cover_every_triple_brightest_first():
    triples = brightness_triples(6)
    assert sorted(triples) == list(itertools.combinations(range(6), 3))
    assert triples[:4] == [(0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3)]


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
