"""Radial features: hand-made bits, the catalog table against brute force, self-match."""

import math

import numpy as np
import pytest

from startrack.camera import Camera
from startrack.database import StarDatabase
from startrack.database._radial import (
    n_rings,
    observed_masks,
    popcount_rows,
    radial_features,
)
from startrack.sky import random_sky


def _at(angle: float, azimuth: float) -> np.ndarray:
    """Unit vector ``angle`` away from +z, towards ``azimuth``."""
    return np.array([math.sin(angle) * math.cos(azimuth), math.sin(angle) * math.sin(azimuth),
                     math.cos(angle)])


def _bits(packed: np.ndarray, nq: int) -> set[int]:
    return set(np.flatnonzero(np.unpackbits(packed, count=nq)).tolist())


@pytest.fixture(scope="module")
def small_db():
    catalog = random_sky(400, seed=11)
    return StarDatabase(catalog, Camera.from_fov(512, 512, 30.0))


def test_hand_made_configuration_sets_expected_rings():
    dr, radius = 0.01, 0.1  # ten rings
    centre = _at(0.0, 0.0)
    neighbours = np.array([_at(0.015, 0.3), _at(0.035, 1.0), _at(0.036, 2.5),
                           _at(0.095, 4.0), _at(0.12, 5.0), centre])
    packed = radial_features(centre, neighbours, radius, dr)
    assert packed.shape == (1, 2) and packed.dtype == np.uint8
    # 0.12 lies beyond R and the centre itself is not its own neighbour.
    assert _bits(packed[0], 10) == {1, 3, 9}
    assert popcount_rows(packed)[0] == 3


def test_ring_count_rounds_up():
    assert n_rings(0.1, 0.01) == 10
    assert n_rings(0.105, 0.01) == 11


def test_catalog_table_matches_brute_force(small_db):
    radius, dr = math.radians(8.0), math.radians(0.15)
    table = small_db.radial(radius, dr)
    brute = radial_features(small_db.vectors, small_db.vectors, radius, dr)
    assert table.bits.shape == brute.shape
    np.testing.assert_array_equal(table.bits, brute)
    assert table.count.sum() > 0
    # The cached copy loads back identical.
    again = StarDatabase(small_db.catalog, small_db.camera).radial(radius, dr)
    np.testing.assert_array_equal(again.bits, table.bits)


def test_spread_means_either_of_two_rings(small_db):
    table = small_db.radial(math.radians(8.0), math.radians(0.15))
    nq = table.n_rings
    bits = np.unpackbits(table.bits, axis=1, count=nq).astype(bool)
    spread = np.unpackbits(table.spread, axis=1, count=nq).astype(bool)
    np.testing.assert_array_equal(spread[:, :-1], bits[:, :-1] | bits[:, 1:])
    np.testing.assert_array_equal(spread[:, -1], bits[:, -1])


def test_observed_masks_tolerate_ring_edges():
    dr, radius, tol = 0.01, 0.1, 0.001
    vectors = np.array([_at(0.0, 0.0), _at(0.025, 0.0),  # mid-ring: ring 2 only
                        _at(0.0395, 1.0),  # near the 3|4 edge: ring 3 or 4
                        _at(0.0605, 2.0),  # near the 5|6 edge: ring 5 or 6
                        _at(0.0995, 3.0),  # may lie either side of R: left out
                        ])
    single, double, need = observed_masks(vectors, np.array([0]), radius, dr, tol)
    assert _bits(single[0], 10) == {2}
    assert _bits(double[0], 10) == {3, 5}
    assert need[0] == 3


def test_star_matches_itself_fully(small_db):
    radius, dr = math.radians(8.0), math.radians(0.15)
    table = small_db.radial(radius, dr)
    rng = np.random.default_rng(5)
    for row in rng.choice(len(small_db.vectors), 10, replace=False):
        near = small_db.cone(small_db.vectors[row], radius * 0.999)
        vectors = small_db.vectors[np.concatenate([[row], near[near != row]])]
        for tol in (0.0, 0.3 * dr):
            single, double, need = observed_masks(vectors, np.array([0]), radius, dr, tol)
            l = table.scores(single[0], double[0])
            assert l[row] == need[0]  # a 100% match score
            rows, _ = table.shortlist(single[0], double[0], int(need[0]), 0.75, 5)
            if need[0] >= 3:
                assert row in rows
