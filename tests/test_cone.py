"""The catalog cone lookup: every row within the radius and no other, anywhere on the sky."""

from __future__ import annotations

import math

import numpy as np
import pytest

from startrack.database.cone import ConeIndex


@pytest.mark.parametrize("radius_deg", [0.5, 14.4, 60.0, 179.0, 200.0])
def test_cone_rows_are_the_brute_force_answer(radius_deg):
    rng = np.random.default_rng(int(radius_deg * 10))
    vectors = rng.normal(size=(20000, 3))
    vectors /= np.linalg.norm(vectors, axis=1, keepdims=True)
    index = ConeIndex.build(vectors)
    radius = math.radians(radius_deg)
    directions = rng.normal(size=(40, 3))
    directions[:4] = [[0, 0, 1], [0, 0, -1], [1, 0, 0], [0, 0.6, -0.8]]  # poles, equator
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    for d in directions:
        got = index.rows(d, radius)
        want = np.flatnonzero(vectors @ d >= math.cos(min(radius, math.pi)))
        np.testing.assert_array_equal(got, want)
    assert len(index.rows(directions[0], radius)) > 0
