"""Verification: right hypotheses are accepted and refined, wrong ones never are."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pandas as pd
import pytest
from startrack._core.verify.entry_points import ACCEPTED
from synth import synthetic_frame

from startrack.attitude import (
    angle_between_deg,
    boresight_error_arcsec,
    random_attitudes,
    solve_wahba,
)
from startrack.camera import Camera
from startrack.database import StarDatabase
from startrack.defaults import DEFAULT_METHOD
from startrack.match_records import Hypothesis, Observation
from startrack.matchers import available_methods, get_matcher
from startrack.sky import SkySpec, load_sky, random_sky
from startrack.solver import identify
from startrack.verify._frame import FrameVerifier
from startrack.verify._verification import VerifyConfig, false_match_probability, verify

CONFIG = VerifyConfig()


@pytest.fixture(scope="module")
def random_db() -> StarDatabase:
    return StarDatabase(random_sky(2000, seed=3), Camera.from_fov(1024, 1024, 17.5))


@pytest.fixture(scope="module")
def hip_db() -> StarDatabase:
    return StarDatabase(load_sky(SkySpec(kind="hipparcos", mag_limit=6.5)),
                        Camera.from_fov(1024, 1024, 20.0))


def _frames(db, n, seed, **kw):
    rng = np.random.default_rng(seed)
    for rot in random_attitudes(n, rng):
        frame = synthetic_frame(db.catalog, db.camera, rot, rng, **kw)
        if len(frame.obs) >= 8:
            yield frame, rng


def _random_obs(camera: Camera, rng, n: int, sigma_px: float = 0.3) -> Observation:
    return Observation.from_pixels(rng.uniform(0, camera.width - 1, n),
                                   rng.uniform(0, camera.height - 1, n), camera, sigma_px)


def test_correct_hypothesis_accepted_and_refined(random_db):
    errors = []
    for frame, _ in _frames(random_db, 10, seed=1, noise_px=0.3):
        obs, truth = frame.obs, frame.truth_rows
        hyp = Hypothesis(np.arange(3), truth[:3])
        result = verify(hyp, obs, random_db, CONFIG)
        assert result.accepted
        assert result.false_probability <= CONFIG.max_false_probability
        assert result.confirmed >= CONFIG.min_confirmed
        # Every star is identified, and correctly.
        order = np.argsort(result.obs_index)
        np.testing.assert_array_equal(result.obs_index[order], np.arange(len(obs)))
        np.testing.assert_array_equal(result.cat_index[order], truth)
        # Refined on all stars: boresight within arcsec (0.3 px is 19 arcsec per star; roll
        # about the boresight is known less well, from lever arms of a few hundred px).
        assert boresight_error_arcsec(result.rotation, frame.rotation) < 15.0
        assert angle_between_deg(result.rotation, frame.rotation) * 3600 < 120.0
        three = solve_wahba(obs.vectors[:3], random_db.vectors[truth[:3]])
        errors.append((boresight_error_arcsec(result.rotation, frame.rotation),
                       boresight_error_arcsec(three, frame.rotation)))
    assert len(errors) >= 5
    refined, three_star = np.array(errors).T
    assert np.mean(refined) < 0.5 * np.mean(three_star)  # refinement pays off on average


def test_exact_centroids_give_exact_attitude(random_db):
    frame, _ = next(_frames(random_db, 5, seed=2))
    result = verify(Hypothesis(np.arange(3), frame.truth_rows[:3]), frame.obs, random_db,
                    CONFIG)
    assert result.accepted
    assert angle_between_deg(result.rotation, frame.rotation) * 3600 < 0.01


def test_wrong_hypotheses_refused(random_db):
    for frame, rng in _frames(random_db, 10, seed=4, noise_px=0.3):
        obs, truth = frame.obs, frame.truth_rows
        # The right stars, the catalog rows swapped among them.
        for perm in ([1, 2, 0], [0, 2, 1], [2, 1, 0]):
            assert not verify(Hypothesis(np.arange(3), truth[perm]), obs, random_db,
                              CONFIG).accepted
        # Random catalog rows.
        for _ in range(20):
            rows = rng.choice(len(random_db.catalog), 3, replace=False)
            assert not verify(Hypothesis(np.arange(3), rows), obs, random_db, CONFIG).accepted


def test_duplicate_rows_refused(random_db):
    frame, _ = next(_frames(random_db, 5, seed=5, noise_px=0.1))
    t = frame.truth_rows
    assert not verify(Hypothesis(np.arange(3), np.array([t[0], t[1], t[1]])), frame.obs,
                      random_db, CONFIG).accepted
    assert not verify(Hypothesis(np.array([0, 1, 1]), t[:3]), frame.obs, random_db,
                      CONFIG).accepted


def test_too_few_other_stars_never_accepted(random_db):
    for frame, _ in _frames(random_db, 5, seed=6, noise_px=0.1):
        for n in (3, 4):  # the hypothesis stars plus at most one other
            sub = Observation(frame.obs.vectors[:n], frame.obs.x[:n], frame.obs.y[:n],
                              frame.obs.camera, frame.obs.sigma_rad)
            result = verify(Hypothesis(np.arange(3), frame.truth_rows[:3]), sub, random_db,
                            CONFIG)
            assert not result.accepted


def test_false_match_probability_behaviour():
    base = dict(n_other=20, n_confirmed=3, n_catalog_in_image=60, radius_px=1.2,
                width=1024, height=1024)
    p = false_match_probability(**base)
    assert 0.0 < p < 1.0
    radii = [false_match_probability(**{**base, "radius_px": r}) for r in (0.5, 1, 2, 4, 8)]
    assert all(a < b for a, b in zip(radii, radii[1:], strict=False))
    dens = [false_match_probability(**{**base, "n_catalog_in_image": n})
            for n in (10, 30, 100, 300)]
    assert all(a < b for a, b in zip(dens, dens[1:], strict=False))
    by_count = [false_match_probability(**{**base, "n_confirmed": k}) for k in range(0, 21)]
    assert by_count[0] == 1.0
    assert all(a > b for a, b in zip(by_count[1:], by_count[2:], strict=False))
    assert false_match_probability(**{**base, "n_confirmed": 0}) == 1.0


def _consistent_triangles(obs: Observation, db: StarDatabase, tri, tol: float) -> np.ndarray:
    """Every catalog triple whose three angles match the observed triangle's (a wrong
    hypothesis a matcher could well propose for random centroids)."""
    v = obs.vectors

    def side(a, b, names):
        theta = float(np.arccos(np.clip(v[a] @ v[b], -1, 1)))
        i, j, _ = db.pairs.query(theta - tol, theta + tol)
        return pd.DataFrame({names[0]: np.r_[i, j].astype(np.int64),
                             names[1]: np.r_[j, i].astype(np.int64)})

    i, j, k = tri
    joined = side(i, j, "ab").merge(side(i, k, "ac"), on="a").merge(side(j, k, "bc"),
                                                                    on=["b", "c"])
    return joined[["a", "b", "c"]].to_numpy()


def test_geometrically_consistent_wrong_triangles_refused(hip_db):
    """Random centroids, hypotheses whose angles match the catalog: verification must
    refuse every one (this is what stands between a matcher and a false solution)."""
    rng = np.random.default_rng(7)
    tried = 0
    for _ in range(20):
        obs = _random_obs(hip_db.camera, rng, int(rng.integers(10, 41)))
        tol = 4.0 * np.sqrt(2.0) * obs.sigma_rad
        for tri in ((0, 1, 2), (0, 1, 3), (1, 2, 3)):
            for rows in _consistent_triangles(obs, hip_db, tri, tol)[:100]:
                tried += 1
                assert not verify(Hypothesis(np.array(tri), rows), obs, hip_db,
                                  CONFIG).accepted
    assert tried > 200  # the test really exercised verification


@pytest.mark.skipif(DEFAULT_METHOD not in available_methods(),
                    reason="the default matcher is not in the tree yet")
def test_random_centroids_never_solved_by_default_method(hip_db):
    matcher = get_matcher(DEFAULT_METHOD)(hip_db)
    matcher.prepare()
    rng = np.random.default_rng(11)
    for _ in range(60):  # scripts/validation/false_positives.py runs 1,000
        obs = _random_obs(hip_db.camera, rng, int(rng.integers(10, 41)))
        assert not identify(obs, matcher, CONFIG).solved


def test_refinement_beyond_the_cone_margin_gives_the_same_answer(random_db, monkeypatch):
    """When refinement moves the boresight beyond the cone's margin, the compiled check
    looks a fresh cone up and refines again there; forcing that on every frame (no margin
    at all) must give the same identities and attitude."""
    from startrack.verify import _frame

    cases = [(Hypothesis(np.arange(3), f.truth_rows[:3]), f.obs)
             for f, _ in _frames(random_db, 6, seed=4, noise_px=0.5, false_stars=2)
             if np.all(f.truth_rows[:3] >= 0)]
    plain = [verify(h, obs, random_db, CONFIG) for h, obs in cases]
    monkeypatch.setattr(_frame, "CONE_REUSE_FRACTION", 0.0)
    forced = [verify(h, obs, random_db, CONFIG) for h, obs in cases]
    cones = [_frame.FrameVerifier(obs, random_db, CONFIG).check(
        np.asarray(h.obs_index, np.int64), np.asarray(h.cat_index, np.int64)).cones
        for h, obs in cases]
    accepted = [p.accepted for p in plain]
    assert sum(accepted) > 0 and all(c >= 2 for c, a in zip(cones, accepted, strict=True) if a)
    for a, b in zip(plain, forced, strict=True):
        assert a.accepted == b.accepted
        np.testing.assert_array_equal(a.obs_index, b.obs_index)
        np.testing.assert_array_equal(a.cat_index, b.cat_index)
        if a.accepted:
            np.testing.assert_allclose(a.matrix, b.matrix, atol=1e-9)


def test_verdicts_keep_their_arrays_while_later_checks_reuse_the_buffers(random_db):
    """A check works in the thread's reused buffers; what it returns must stay its own."""
    def fields(v):
        return [np.array(getattr(v, k), copy=True) for k in
                ("first", "obs", "rows", "final", "residuals", "quaternion")]

    frames = [f for f, _ in _frames(random_db, 6, seed=7, noise_px=0.3)][:3]
    checkers = [FrameVerifier(f.obs, random_db, CONFIG) for f in frames]
    hyps = [(np.arange(3, dtype=np.int64), f.truth_rows[:3].astype(np.int64)) for f in frames]
    first = [c.check(*h) for c, h in zip(checkers, hyps, strict=True)]
    assert all(v.status == ACCEPTED for v in first)
    kept = [fields(v) for v in first]
    wrong = np.array([0, 1, 2], np.int64), np.array([5, 900, 1700], np.int64)
    for c, h in zip(reversed(checkers), reversed(hyps), strict=True):  # other frame sizes
        c.check(*wrong)
        again = c.check(*h)
    for v, before, c, h in zip(first, kept, checkers, hyps, strict=True):
        for a, b, c_ in zip(fields(v), before, fields(c.check(*h)), strict=True):
            np.testing.assert_array_equal(a, b)
            np.testing.assert_array_equal(a, c_)
    assert again.status == ACCEPTED
    result = verify(Hypothesis(*hyps[0]), frames[0].obs, random_db, CONFIG)
    assert result == replace(result)  # the fast-made Verification is a plain dataclass one
    np.testing.assert_array_equal(result.quaternion, first[0].quaternion)
