"""The quad search where the sky is sparse: a deeper pattern level, the brightest stars."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from startrack.camera import Camera, stars_in_view
from startrack.database import _quads as Q
from startrack.match_records import Hypothesis, Observation
from startrack.sky import Catalog, SkySpec, random_sky
from startrack.solver._fov_fit import BRIGHTEST, verify_fitted
from startrack.solver._fov_search import BlindSolver, focal_range
from startrack.verify import VerifyConfig, verify

CAMERA = Camera.from_fov(1024, 1024, 20.0)
ROT = Rotation.from_euler("zyx", [30, -20, 10], degrees=True)


def _sparse_sky() -> Catalog:
    """20000 random stars; within 25 deg of ``ROT``'s boresight every star is fainter than
    the pattern stars of the 20 deg frame's level, its brightest tenth among the next
    level's."""
    sky = random_sky(20000, seed=3, mag_max=9.0)
    mag = sky.mag.copy()
    near = sky.vectors @ ROT.apply([0.0, 0.0, 1.0]) > math.cos(math.radians(25.0))
    level = Q.level_for(CAMERA.fov_deg)
    far = np.sort(mag[~near])
    lo = far[Q.level_stars(level) + 200]
    hi = far[Q.level_stars(level / Q.LEVEL_STEP) - 200]
    rng = np.random.default_rng(4)
    k = np.flatnonzero(near)
    bright = rng.random(len(k)) < 0.1
    mag[k] = np.where(bright, rng.uniform(lo, hi, len(k)), rng.uniform(hi + 0.01, 12, len(k)))
    return Catalog(sky.ids, sky.ra_deg, sky.dec_deg, mag, source={"sky": "sparse-test"})


@pytest.fixture(scope="module")
def frame():
    catalog = _sparse_sky()
    rows, x, y = stars_in_view(catalog, CAMERA, ROT)
    rng = np.random.default_rng(5)
    return catalog, rows, x + rng.normal(0, 0.3, len(x)), y + rng.normal(0, 0.3, len(y))


def test_a_sparse_patch_is_found_one_level_deeper(frame):
    catalog, rows, x, y = frame
    level_rows = Q.level_stars(Q.level_for(CAMERA.fov_deg))
    assert np.count_nonzero(rows[:Q.K_NEAREST] < level_rows) < 4  # no pattern at its level
    solver = BlindSolver(catalog, SkySpec(kind="random"), 0.5)
    lo, hi = focal_range(CAMERA, 0.05)
    diag = solver.matcher.scaled(x, y, CAMERA, lo, hi, _Diag(), solver.database_for(CAMERA))
    assert not any(np.array_equal(rows[h.hypothesis.obs_index], h.hypothesis.cat_index)
                   for h in diag)
    result = solver.solve(x, y, (1024, 1024), camera=CAMERA, tolerance=0.05)
    sol = result.solution
    assert sol.solved
    assert np.array_equal(rows[sol.obs_index], sol.cat_index)  # every star named right
    assert result.camera.fov_deg == pytest.approx(CAMERA.fov_deg, abs=0.01)


def test_a_full_level_has_no_deeper_one():
    solver = BlindSolver(random_sky(2000, seed=1), SkySpec(kind="random"), 0.5)
    assert solver.matcher.deeper_levels(20.0) == 0  # every star is a pattern star already
    assert solver.matcher.scaled(np.zeros(4), np.zeros(4), CAMERA, 900, 1100, _Diag(),
                                 deeper=1) == []


def test_the_brightest_stars_confirm_what_faint_junk_hides(frame):
    """Seven true stars among 60 random detections, the catalog holding just those seven
    in view: the bound over the whole frame fails, the same bound over the brightest
    stars alone passes, and only for the right stars."""
    sky, rows, x, y = frame
    from startrack.database import StarDatabase

    other = random_sky(2000, seed=7, mag_min=3.0)
    out = other.vectors @ ROT.apply([0.0, 0.0, 1.0]) < math.cos(math.radians(20.0))
    catalog = Catalog(np.arange(7 + out.sum()),
                      np.concatenate([sky.ra_deg[rows[:7]], other.ra_deg[out]]),
                      np.concatenate([sky.dec_deg[rows[:7]], other.dec_deg[out]]),
                      np.concatenate([np.linspace(1.0, 2.0, 7), other.mag[out]]),
                      source={"sky": "seven-test"})
    db = StarDatabase(catalog, CAMERA)
    rng = np.random.default_rng(6)
    bx = np.concatenate([x[:7], rng.uniform(0, 1023, 60)])
    by = np.concatenate([y[:7], rng.uniform(0, 1023, 60)])
    truth = np.arange(7)
    found = verify_fitted(Hypothesis(np.arange(4), truth[:4]), bx, by, CAMERA, 0.5, db,
                          VerifyConfig())
    assert found is not None
    check, fitted, obs = found
    assert len(obs) == len(bx)  # every detection, through the fitted camera
    assert np.array_equal(check.obs_index, truth) and np.array_equal(check.cat_index, truth)
    assert fitted.fov_deg == pytest.approx(CAMERA.fov_deg, abs=0.01)
    whole = verify(Hypothesis(np.arange(4), truth[:4]),
                   Observation.from_pixels(bx, by, CAMERA, 0.5), db, VerifyConfig())
    assert not whole.accepted  # the brightest stars alone made the difference
    swapped = Hypothesis(np.arange(4), truth[[1, 0, 2, 3]])
    assert verify_fitted(swapped, bx, by, CAMERA, 0.5, db, VerifyConfig()) is None
    short = verify_fitted(Hypothesis(np.arange(4), truth[:4]), bx[:BRIGHTEST - 1],
                          by[:BRIGHTEST - 1], CAMERA, 0.5, db, VerifyConfig())
    assert short is not None  # fewer detections than BRIGHTEST: the whole frame decides


class _Diag:
    candidates = 0
