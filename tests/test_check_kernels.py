"""The one-call verification (startrack.matching.check_kernels) against the steps it fuses:
scipy's binomial tail, scipy's Rotation, and verify() step by step."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from scipy.special import bdtrc
from synth import synthetic_frame

from startrack.attitude import random_attitudes
from startrack.camera._model import Camera
from startrack.database import StarDatabase
from startrack.matching import check_kernels
from startrack.matching.projector import CatalogProjector
from startrack.matching.wahba_kernels import matrix_to_quaternion
from startrack.sky import random_sky
from startrack.types import Hypothesis
from startrack.verify._verification import VerifyConfig, _verify_steps, rotation_of, verify

CONFIG = VerifyConfig()


@pytest.fixture(scope="module")
def random_db() -> StarDatabase:
    return StarDatabase(random_sky(2000, seed=3), Camera.from_fov(1024, 1024, 17.5))


def test_binomial_tail_agrees_with_scipy():
    """Over the counts and densities verification meets, within 1e-12 relative, and 0
    exactly where scipy's underflows."""
    worst, checked = 0.0, 0
    for n in (*range(1, 61), 80, 120, 200, 300):
        for p in (*np.logspace(-7, -0.3, 25), 0.9):
            for k in range(-1, n + 1):
                ref, got = bdtrc(k, n, p), check_kernels.binomial_tail(k, n, p)
                if ref == 0.0 or got == 0.0:
                    assert ref == got or max(ref, got) < 1e-290, (k, n, p, ref, got)
                    continue
                worst = max(worst, abs(got - ref) / ref)
                checked += 1
    assert checked > 10000
    assert worst <= 1e-12


def test_binomial_tail_edges():
    assert check_kernels.binomial_tail(-1, 10, 0.1) == 1.0
    assert check_kernels.binomial_tail(10, 10, 0.1) == 0.0
    assert check_kernels.binomial_tail(3, 10, 0.0) == 0.0
    assert check_kernels.binomial_tail(3, 10, 1.0) == 1.0
    tail = [check_kernels.binomial_tail(k, 40, 1e-3) for k in range(40)]
    assert all(a > b for a, b in zip(tail, tail[1:], strict=False) if b > 0.0)


def test_rotation_of_is_from_quat():
    """The Rotation built from the pickled state holds exactly what from_quat builds."""
    rng = np.random.default_rng(5)
    for rot in random_attitudes(200, rng):
        matrix = np.ascontiguousarray(rot.as_matrix())
        fast, ref = rotation_of(matrix), Rotation.from_quat(matrix_to_quaternion(matrix))
        assert fast.single
        np.testing.assert_array_equal(fast.as_quat(canonical=False), ref.as_quat(canonical=False))
        np.testing.assert_array_equal(fast.as_matrix(), ref.as_matrix())
        assert (fast * ref.inv()).magnitude() == pytest.approx(0.0, abs=1e-12)


def _same(a, b):
    assert a.accepted == b.accepted
    np.testing.assert_array_equal(a.obs_index, b.obs_index)
    np.testing.assert_array_equal(a.cat_index, b.cat_index)
    assert a.confirmed == b.confirmed
    assert a.false_probability == pytest.approx(b.false_probability, rel=1e-12, abs=0.0)
    if a.matrix is None or b.matrix is None:
        assert a.matrix is None and b.matrix is None
    else:
        np.testing.assert_array_equal(a.matrix, b.matrix)
        np.testing.assert_array_equal(a.rotation.as_quat(), b.rotation.as_quat())


@pytest.mark.parametrize("fixed", [False, True])
def test_one_call_is_the_steps(random_db, fixed):
    """verify()'s one compiled call gives what its steps give one by one (the path it
    keeps for unusual input): right hypotheses, wrong ones, too few confirmations."""
    rng = np.random.default_rng(21)
    cases = 0
    for rot in random_attitudes(12, rng):
        frame = synthetic_frame(random_db.catalog, random_db.camera, rot, rng, noise_px=0.5,
                                false_stars=3)
        obs, truth = frame.obs, frame.truth_rows
        real = np.flatnonzero(truth >= 0)
        if len(real) < 6:
            continue
        radius = CONFIG.radius_px(obs)
        rows = random_db.cone(rot.as_matrix()[:, 2], np.radians(14.0)) if fixed else None
        hyps = [Hypothesis(real[:3], truth[real[:3]]), Hypothesis(real[:4], truth[real[:4]]),
                Hypothesis(real[:3], truth[real[[1, 0, 2]]]),
                Hypothesis(real[:3], rng.choice(len(random_db.vectors), 3, replace=False))]
        for hyp in hyps:
            one = verify(hyp, obs, random_db, CONFIG,
                         CatalogProjector(obs, random_db, radius, rows))
            steps = _verify_steps(np.asarray(hyp.obs_index, np.int64),
                                  np.asarray(hyp.cat_index, np.int64), obs, random_db,
                                  CONFIG, CatalogProjector(obs, random_db, radius, rows))
            _same(one, steps)
            cases += one.accepted
    assert cases >= 10


def test_unusual_hypotheses_take_the_steps(random_db):
    """Repeated or out-of-range stars go step by step: refused, or numpy's IndexError."""
    rng = np.random.default_rng(2)
    frame = synthetic_frame(random_db.catalog, random_db.camera,
                            random_attitudes(1, rng)[0], rng, noise_px=0.3)
    t = frame.truth_rows
    assert not verify(Hypothesis(np.array([0, 1, 1]), t[:3]), frame.obs, random_db,
                      CONFIG).accepted
    with pytest.raises(IndexError):
        verify(Hypothesis(np.arange(3), np.array([t[0], t[1], 10**7])), frame.obs, random_db,
               CONFIG)
