"""The compiled verification held to the numba kernels it replaces, to the bit, while both
exist (the numba ones go once tracking calls the compiled verification; then this file
goes with them). Slow: numba compiles its kernels on a first run."""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_core_verify import _cases
from test_matching import _random_frames

from startrack._core import _nearest
from startrack.attitude import random_attitudes
from startrack.camera import Camera
from startrack.database import StarDatabase
from startrack.matching import check_kernels
from startrack.matching.cone_kernels import cone_rows
from startrack.matching.nearest_kernels import nearest_matches, pairs_within
from startrack.sky import random_sky
from startrack.verify._frame import (
    CAPTURE,
    CONE_LOOKUP_MARGIN,
    MAX_REFINEMENTS,
    FrameVerifier,
    cone_radius,
)
from startrack.verify._labelling import kernel_params
from startrack.verify._verification import VerifyConfig

pytestmark = pytest.mark.slow
CONFIG = VerifyConfig()


@pytest.fixture(scope="module")
def random_db() -> StarDatabase:
    return StarDatabase(random_sky(2000, seed=3), Camera.from_fov(1024, 1024, 17.5))


def _numba_check(obs, db, rows, obs_h, cat_h):
    """check_kernels' verdict: (status, first matrix, obs, rows, prob, confirmed, final,
    residuals)."""
    radius = CONFIG.radius_px(obs)
    cone = cone_radius(obs.camera)
    params = check_kernels.pack_params(
        radius, math.cos(radius / obs.camera.f_px), cone * CONE_LOOKUP_MARGIN,
        -2.0 if rows is not None else math.cos(0.01 * cone), CAPTURE, MAX_REFINEMENTS,
        CONFIG.min_confirmed, CONFIG.max_false_probability, kernel_params(obs, radius))
    v, x, y = (np.ascontiguousarray(a, dtype=np.float64) for a in (obs.vectors, obs.x, obs.y))
    mags, index = db.catalog.mag, db.cone_index
    if rows is not None:
        return check_kernels.check_fixed(
            v, x, y, obs.kernel_flux(), obs_h, cat_h, index.vectors, rows,
            np.ascontiguousarray(db.vectors[rows]), np.ascontiguousarray(mags[rows]),
            obs.camera.geometry, params)[:8]
    out = check_kernels.check_cone(v, x, y, obs.kernel_flux(), obs_h, cat_h, index.vectors,
                                   mags, index.order, index.ra_sorted, index.band_start,
                                   obs.camera.geometry, params)
    return (out[0], out[1], *out[4:10])


@pytest.mark.parametrize("fixed", [False, True])
def test_check_is_the_numba_check(random_db, fixed):
    rng = np.random.default_rng(21)
    statuses = []
    for hyp, obs, rows in _cases(random_db, rng, 10, fixed):
        obs_h, cat_h = (np.asarray(a, np.int64) for a in (hyp.obs_index, hyp.cat_index))
        want = _numba_check(obs, random_db, rows, obs_h, cat_h)
        got = FrameVerifier(obs, random_db, CONFIG, rows).check(obs_h, cat_h)
        statuses.append(got.status)
        assert got.status == want[0]
        if got.status > 0:
            np.testing.assert_array_equal(got.first, want[1])
        if got.status > 1:
            np.testing.assert_array_equal(got.obs, want[2])
            np.testing.assert_array_equal(got.rows, want[3])
            assert (got.probability, got.confirmed) == (want[4], want[5])
        if got.status == 3:
            np.testing.assert_array_equal(got.final, want[6])
            np.testing.assert_array_equal(got.residuals, want[7])
    assert {1, 2, 3} <= set(statuses)


def test_nearest_and_pairs_are_the_numba_ones():
    for t, rng, scale, cx, cy, ox, oy in _random_frames(23, 600, (1.0, 200.0, 1e6, 1e-3)):
        if t % 5 == 0:
            cx[rng.integers(len(cx))] = np.nan
        radius = (0.0, scale / 100, scale / 20, 3 * scale)[t % 4]
        for got, want in zip(_nearest.matches(ox, oy, cx, cy, radius),
                             nearest_matches(ox, oy, cx, cy, radius), strict=True):
            np.testing.assert_array_equal(got, want)
        for got, want in zip(_nearest.pairs(ox, oy, cx, cy, radius**2),
                             pairs_within(ox, oy, cx, cy, radius**2), strict=True):
            np.testing.assert_array_equal(got, want)


def test_cone_rows_are_the_numba_ones(random_db):
    rng = np.random.default_rng(5)
    index = random_db.cone_index
    for rot in random_attitudes(300, rng):
        d = np.ascontiguousarray(rot.as_matrix()[:, 2])
        r = float(rng.choice([0.0, 0.05, 0.2, 1.6, math.pi]))
        np.testing.assert_array_equal(
            index.rows(d, r), cone_rows(index.vectors, index.order, index.ra_sorted,
                                        index.band_start, d, r))

