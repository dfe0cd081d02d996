"""The planar-triangle matcher: vertex mapping, pivot joins, whole-frame identification."""

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
from startrack.matchers.planar_triangle import brightness_triples, join_on, map_vertices
from startrack.sky import SkySpec, load_sky, random_sky

METHOD = "triangle"


@pytest.fixture(scope="module")
def random_db() -> StarDatabase:
    return StarDatabase(random_sky(2000, seed=11), Camera.from_fov(1024, 1024, 17.5))


@pytest.fixture(scope="module")
def matcher(random_db):
    m = get_matcher(METHOD)(random_db)
    m.prepare()
    return m


def _frames(db, n, seed, min_stars=8, **kw):
    rng = np.random.default_rng(seed)
    for rot in random_attitudes(n, rng):
        frame = synthetic_frame(db.catalog, db.camera, rot, rng, **kw)
        if np.count_nonzero(frame.truth_rows >= 0) >= min_stars:
            yield frame


def _with_false_star(frame, position: int, rng):
    obs = frame.obs
    x = np.insert(obs.x, position, rng.uniform(0, obs.camera.width - 1))
    y = np.insert(obs.y, position, rng.uniform(0, obs.camera.height - 1))
    return (Observation.from_pixels(x, y, obs.camera, obs.sigma_rad * obs.camera.f_px),
            np.insert(frame.truth_rows, position, -1))


def _assert_correct(solution, truth_rows):
    assert solution.solved
    assert np.all(truth_rows[solution.obs_index] == solution.cat_index)


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


def test_join_on_equals_brute_force():
    rng = np.random.default_rng(5)
    hyps = rng.integers(0, 10, size=(60, 3))
    new = rng.integers(0, 10, size=(80, 3))
    got = join_on(hyps, 1, 2, new)
    want = [(*h, t[2]) for h in hyps.tolist() for t in new.tolist()
            if t[0] == h[1] and t[1] == h[2] and t[2] not in h]
    assert sorted(map(tuple, got.tolist())) == sorted(want)
    assert join_on(hyps, 0, 1, new[:0]).shape == (0, 4)


def test_exact_centroids_identify_every_star(random_db, matcher):
    frames = list(_frames(random_db, 10, seed=21))
    assert len(frames) >= 5
    for frame in frames:
        solution = identify(frame.obs, matcher)
        _assert_correct(solution, frame.truth_rows)
        assert len(solution.obs_index) == len(frame.obs)
        assert angle_between_deg(solution.rotation, frame.rotation) * 3600 < 3.0
        assert solution.diagnostics.candidates > 0


@pytest.mark.slow
def test_exact_centroids_real_sky():
    """Hipparcos needs the pattern-star cap: the brightest stars of a frame are in it."""
    db = StarDatabase(load_sky(SkySpec(kind="hipparcos", mag_limit=6.5)),
                      Camera.from_fov(1024, 1024, 20.0))
    m = get_matcher(METHOD)(db)
    m.prepare()
    assert db.triangles.max_per_region is not None
    for frame in _frames(db, 3, seed=22):
        solution = identify(frame.obs, m)
        assert solution.solved
        assert angle_between_deg(solution.rotation, frame.rotation) * 3600 < 3.0


@pytest.mark.parametrize("position", [0, 2])
def test_one_false_star_among_the_brightest(random_db, matcher, position):
    rng = np.random.default_rng(100 + position)
    for frame in _frames(random_db, 5, seed=23 + position, noise_px=0.1):
        obs, truth = _with_false_star(frame, position, rng)
        solution = identify(obs, matcher)
        _assert_correct(solution, truth)
        assert position not in solution.obs_index.tolist()


def test_mirrored_frame_yields_no_hypothesis(random_db, matcher):
    frame = next(_frames(random_db, 5, seed=27))
    obs = frame.obs
    mirrored = Observation.from_pixels(obs.camera.width - 1 - obs.x, obs.y, obs.camera, 0.05)
    assert not identify(mirrored, matcher).solved


def test_too_few_stars_is_a_clean_not_solved(random_db, matcher):
    frame = next(_frames(random_db, 5, seed=41))
    for n in (0, 1, 2, 3):
        obs = Observation.from_pixels(frame.obs.x[:n], frame.obs.y[:n], frame.obs.camera, 0.1)
        solution = identify(obs, matcher)
        assert not solution.solved and solution.rotation is None
    # Three real stars: the right triangle is proposed, but nothing confirms it.
    obs = Observation.from_pixels(frame.obs.x[:3], frame.obs.y[:3], frame.obs.camera, 0.1)
    found = list(matcher.hypotheses(obs, MatchDiagnostics()))
    assert any(np.array_equal(frame.truth_rows[h.obs_index], h.cat_index) for h in found)


def test_random_centroids_never_solve(random_db, matcher):
    rng = np.random.default_rng(51)
    camera = random_db.camera
    for _ in range(50):
        n = int(rng.integers(3, 20))
        obs = Observation.from_pixels(rng.uniform(0, camera.width - 1, n),
                                      rng.uniform(0, camera.height - 1, n), camera, 0.3)
        assert not identify(obs, matcher).solved


def test_noisy_monte_carlo(random_db, matcher):
    """0.3 px noise, one false star, 10% missing: at least 90% solved, none wrong."""
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


def test_wide_tolerance_forces_pivots(random_db):
    """With 40-sigma windows one triangle matches many catalog triangles; pivoting on
    triangles that share two stars narrows them down to the right one."""
    from startrack.matchers import MatcherConfig

    m = get_matcher(METHOD)(random_db, MatcherConfig(tolerance_sigma=40.0))
    frame = next(_frames(random_db, 5, seed=71, noise_px=0.3))
    diag = MatchDiagnostics()
    first = next(iter(m.hypotheses(frame.obs, diag)))
    assert diag.pivots >= 1 and len(first.obs_index) >= 4
    assert np.all(frame.truth_rows[first.obs_index] == first.cat_index)
