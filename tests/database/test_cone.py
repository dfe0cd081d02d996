"""The catalog cone lookup: every row within the radius and no other, anywhere on the sky;
the cuts of a brightest-first catalog (its first rows) kept within their byte budget."""

from __future__ import annotations

import math

import numpy as np
import pytest

from startrack.database._cone import ConeIndex, CutCones


@pytest.mark.parametrize("radius_deg", [0.5, 14.4, 60.0, 89.9, 179.0, 200.0])
def test_cone_rows_are_the_brute_force_answer(radius_deg):
    rng = np.random.default_rng(int(radius_deg * 10))
    vectors = rng.normal(size=(20000, 3))
    vectors /= np.linalg.norm(vectors, axis=1, keepdims=True)
    index = ConeIndex.build(vectors)
    radius = math.radians(radius_deg)
    directions = rng.normal(size=(40, 3))
    # Poles, equator, RA 0 (the windows wrap), beside a pole and on a band edge.
    directions[:8] = [[0, 0, 1], [0, 0, -1], [1, 0, 0], [0, 0.6, -0.8], [1, -1e-9, 0.1],
                      [1, 1e-9, -0.3], [0.05, 0.0, 1.0], [math.cos(math.radians(30.0)), 0.0,
                                                        math.sin(math.radians(30.0))]]
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    for d in directions:
        got = index.rows(d, radius)
        want = np.flatnonzero(vectors @ d >= math.cos(min(radius, math.pi)))
        np.testing.assert_array_equal(got, want)
    assert len(index.rows(directions[0], radius)) > 0


def test_cone_rows_on_band_and_ra_edges():
    """Stars placed exactly on declination band edges, at RA 0 and 2 pi, and at the
    poles are found as a brute-force test finds them."""
    dec = np.radians(np.repeat(np.arange(-90.0, 90.5, 1.0), 8))
    ra = np.tile(np.radians([0.0, 1e-12, 90.0, 180.0, 270.0, 359.999999, 360.0 - 1e-12,
                             45.0]), len(dec) // 8)
    vectors = np.column_stack([np.cos(dec) * np.cos(ra), np.cos(dec) * np.sin(ra),
                               np.sin(dec)])
    index = ConeIndex.build(vectors)
    for d_dec, d_ra, r in [(0.0, 0.0, 1.0), (45.0, 359.5, 2.0), (-89.0, 10.0, 1.0),
                           (88.5, 180.0, 1.5), (10.0, 0.5, 20.0), (-30.0, 359.9, 0.2)]:
        d = np.array([math.cos(math.radians(d_dec)) * math.cos(math.radians(d_ra)),
                      math.cos(math.radians(d_dec)) * math.sin(math.radians(d_ra)),
                      math.sin(math.radians(d_dec))])
        want = np.flatnonzero(vectors @ d >= math.cos(math.radians(r)))
        np.testing.assert_array_equal(index.rows(d, math.radians(r)), want)
        assert len(want) > 0


def _sphere(n: int, seed: int) -> np.ndarray:
    vectors = np.random.default_rng(seed).normal(size=(n, 3))
    return vectors / np.linalg.norm(vectors, axis=1, keepdims=True)


def test_a_cut_is_the_index_of_the_first_rows():
    vectors = _sphere(5000, 3)
    cones = CutCones(ConeIndex.build(vectors), max_bytes=1 << 20)
    for n in (0, 1, 700, 4999, 5000):
        cut, built = cones.cut(n), ConeIndex.build(vectors[:n])
        np.testing.assert_array_equal(cut.order, built.order)
        np.testing.assert_array_equal(cut.band_start, built.band_start)
        d = vectors[0]
        np.testing.assert_array_equal(cut.rows(d, 0.3), built.rows(d, 0.3))


def test_cuts_are_kept_within_their_bytes_latest_first():
    vectors = _sphere(5000, 4)
    one = ConeIndex.build(vectors[:1000]).nbytes
    # room for two such cuts
    cones = CutCones(ConeIndex.build(vectors), max_bytes=2 * one + one // 2)
    first = cones.cut(1000)
    assert cones.cut(1000) is first  # kept: not cut again
    second = cones.cut(999)
    assert cones.cut(1000) is first  # used last now
    cones.cut(998)  # a third: the least recently used (999) goes
    assert cones.cut(1000) is first
    assert cones.cut(999) is not second
    assert sum(c.nbytes for c in cones._cuts.values()) <= cones.max_bytes
    # a cut larger than the budget is made, and not kept
    whole = cones.cut(5000)
    assert cones.cut(5000) is not whole and 5000 not in cones._cuts
