"""The angle method with pivoting: joins, pivot chains, and whole-frame identification."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from synth import synthetic_frame

from startrack.attitude import angle_between_deg, random_attitudes
from startrack.camera import Camera
from startrack.database import StarDatabase
from startrack.identify import identify
from startrack.matchers import MatchDiagnostics, Observation, get_matcher
from startrack.matchers.angle import PairCandidates, join_close, join_extend, smart_triples
from startrack.sky import SkySpec, load_sky, random_sky

METHOD = "angle"


@pytest.fixture(scope="module")
def random_db() -> StarDatabase:
    return StarDatabase(random_sky(2000, seed=11), Camera.from_fov(1024, 1024, 17.5))


@pytest.fixture(scope="module")
def hip_db() -> StarDatabase:
    return StarDatabase(load_sky(SkySpec(kind="hipparcos", mag_limit=6.5)),
                        Camera.from_fov(1024, 1024, 20.0))


def _matcher(db: StarDatabase):
    matcher = get_matcher(METHOD)(db)
    matcher.prepare()
    return matcher


def _frames(db, n, seed, min_stars=8, **kw):
    rng = np.random.default_rng(seed)
    for rot in random_attitudes(n, rng):
        frame = synthetic_frame(db.catalog, db.camera, rot, rng, **kw)
        if np.count_nonzero(frame.truth_rows >= 0) >= min_stars:
            yield frame


def _with_false_star(frame, position: int, rng):
    """The frame with one false star inserted at brightness rank ``position``."""
    obs = frame.obs
    x = np.insert(obs.x, position, rng.uniform(0, obs.camera.width - 1))
    y = np.insert(obs.y, position, rng.uniform(0, obs.camera.height - 1))
    sigma_px = obs.sigma_rad * obs.camera.f_px
    return (Observation.from_pixels(x, y, obs.camera, sigma_px),
            np.insert(frame.truth_rows, position, -1))


def _assert_correct(solution, truth_rows):
    assert solution.solved
    assert np.all(truth_rows[solution.obs_index] == solution.cat_index)


# --- the joins -------------------------------------------------------------------------


def test_join_extend_equals_brute_force():
    rng = np.random.default_rng(5)
    hyps = rng.integers(0, 30, size=(40, 2))
    cp, cq = rng.integers(0, 30, 60), rng.integers(0, 30, 60)
    got = join_extend(hyps, 1, PairCandidates(cp, cq, 30))
    want = [(*h, b) for h in hyps.tolist() for a, b in zip(cp, cq, strict=True)
            if a == h[1] and b not in h]
    assert sorted(map(tuple, got.tolist())) == sorted(want)
    assert join_extend(hyps, 0, PairCandidates(cp[:0], cq[:0], 30)).shape == (0, 3)


def test_join_close_equals_brute_force():
    rng = np.random.default_rng(6)
    hyps = rng.integers(0, 12, size=(80, 3))
    cp, cq = rng.integers(0, 12, 40), rng.integers(0, 12, 40)
    allowed = set(zip(cp.tolist(), cq.tolist(), strict=True))
    got = join_close(hyps, 0, 2, PairCandidates(cp, cq, 12))
    want = [h for h in hyps.tolist() if (h[0], h[2]) in allowed]
    assert got.tolist() == want


def test_smart_triples_cover_every_triple_once_and_spread():
    for n in range(3, 10):
        triples = list(smart_triples(n))
        assert sorted(triples) == list(itertools.combinations(range(n), 3))
    first = list(smart_triples(8))[:6]
    # Star 0 drops out of the tries at once: the second triple avoids it.
    assert first[0] == (0, 1, 2) and 0 not in first[1]


# --- whole frames ----------------------------------------------------------------------


def test_exact_centroids_identify_every_star(random_db):
    matcher = _matcher(random_db)
    frames = list(_frames(random_db, 12, seed=21))
    assert len(frames) >= 5
    for frame in frames:
        solution = identify(frame.obs, matcher)
        _assert_correct(solution, frame.truth_rows)
        assert len(solution.obs_index) == len(frame.obs)
        assert angle_between_deg(solution.rotation, frame.rotation) * 3600 < 3.0
        assert solution.diagnostics.candidates > 0


def test_exact_centroids_real_sky(hip_db):
    matcher = _matcher(hip_db)
    for frame in _frames(hip_db, 3, seed=22):
        solution = identify(frame.obs, matcher)
        _assert_correct(solution, frame.truth_rows)
        assert angle_between_deg(solution.rotation, frame.rotation) * 3600 < 3.0


@pytest.mark.parametrize("position", [0, 1, 3])
def test_one_false_star_among_the_brightest(random_db, position):
    matcher = _matcher(random_db)
    rng = np.random.default_rng(100 + position)
    for frame in _frames(random_db, 6, seed=23 + position, noise_px=0.1):
        obs, truth = _with_false_star(frame, position, rng)
        solution = identify(obs, matcher)
        _assert_correct(solution, truth)
        assert position not in solution.obs_index.tolist()


def test_false_star_first_in_real_sky(hip_db):
    """The chains that start with the false star die; a later ordering solves the frame."""
    matcher = _matcher(hip_db)
    rng = np.random.default_rng(31)
    frame = next(_frames(hip_db, 3, seed=32, noise_px=0.3))
    obs, truth = _with_false_star(frame, 0, rng)
    solution = identify(obs, matcher)
    _assert_correct(solution, truth)
    assert solution.diagnostics.extra["chains"] > 1


def test_too_few_stars_is_a_clean_not_solved(random_db):
    matcher = _matcher(random_db)
    frame = next(_frames(random_db, 5, seed=41))
    for n in (0, 1, 2, 3):
        obs = Observation.from_pixels(frame.obs.x[:n], frame.obs.y[:n], frame.obs.camera, 0.1)
        solution = identify(obs, matcher)
        assert not solution.solved
        assert solution.rotation is None
    # Three real stars resolve to one hypothesis, but nothing confirms it independently.
    obs = Observation.from_pixels(frame.obs.x[:3], frame.obs.y[:3], frame.obs.camera, 0.1)
    assert not identify(obs, matcher).solved
    found = list(matcher.hypotheses(obs, MatchDiagnostics()))
    assert any(np.array_equal(frame.truth_rows[h.obs_index], h.cat_index) for h in found)


def test_random_centroids_never_solve(random_db):
    matcher = _matcher(random_db)
    rng = np.random.default_rng(51)
    camera = random_db.camera
    for _ in range(50):
        n = int(rng.integers(3, 20))
        obs = Observation.from_pixels(rng.uniform(0, camera.width - 1, n),
                                      rng.uniform(0, camera.height - 1, n), camera, 0.3)
        assert not identify(obs, matcher).solved


def test_noisy_monte_carlo(random_db):
    """0.3 px noise, one false star, 10% missing: at least 90% solved, none wrong."""
    matcher = _matcher(random_db)
    rng = np.random.default_rng(61)
    solved = wrong = 0
    frames = 30
    for rot in random_attitudes(frames, rng):
        frame = synthetic_frame(random_db.catalog, random_db.camera, rot, rng, noise_px=0.3,
                                false_stars=1, missing=0.1)
        solution = identify(frame.obs, matcher)
        if solution.solved:
            ok = np.all(frame.truth_rows[solution.obs_index] == solution.cat_index)
            solved += int(ok)
            wrong += int(not ok)
    assert wrong == 0
    assert solved >= 0.9 * frames


def test_pivot_diagnostics_are_counted(random_db):
    matcher = _matcher(random_db)
    frame = next(_frames(random_db, 5, seed=71, noise_px=0.3))
    diag = MatchDiagnostics()
    first = next(iter(matcher.hypotheses(frame.obs, diag)))
    assert len(first.obs_index) >= 3
    assert np.all(frame.truth_rows[first.obs_index] == first.cat_index)
    assert diag.pivots >= 1 and diag.candidates >= 1
    assert diag.extra["lookups"] <= 28
