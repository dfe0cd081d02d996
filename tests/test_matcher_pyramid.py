"""Pyramid: triangles of pair lookups, the mirror check, the fourth star, whole frames."""

from __future__ import annotations

import numpy as np
import pytest
from synth import synthetic_frame

from startrack.attitude import angle_between_deg, random_attitudes
from startrack.camera import Camera
from startrack.database import StarDatabase
from startrack.identify import identify
from startrack.matchers import MatchDiagnostics, Observation, get_matcher
from startrack.matchers.pyramid import triple_products
from startrack.sky import SkySpec, load_sky, random_sky

METHOD = "pyramid"


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


# --- geometry --------------------------------------------------------------------------


def test_triple_product_sign_flips_in_a_mirror():
    rng = np.random.default_rng(4)
    v = rng.normal(size=(3, 20, 3))
    v /= np.linalg.norm(v, axis=2, keepdims=True)
    mirror = v * np.array([-1.0, 1.0, 1.0])
    t, tm = triple_products(*v), triple_products(*mirror)
    np.testing.assert_allclose(tm, -t)
    np.testing.assert_allclose(t, np.linalg.det(np.stack(v, axis=1)))


def test_mirrored_frame_gives_no_true_hypothesis(random_db):
    """A reflected image has every triangle's handedness reversed: Pyramid must not map it
    to the real stars, and nothing is solved."""
    matcher = _matcher(random_db)
    for frame in _frames(random_db, 6, seed=81):
        obs = frame.obs
        mirrored = Observation.from_pixels(obs.camera.width - 1 - obs.x, obs.y, obs.camera, 0.1)
        found = list(matcher.hypotheses(mirrored, MatchDiagnostics()))
        assert not any(np.array_equal(frame.truth_rows[h.obs_index], h.cat_index)
                       for h in found)
        assert not identify(mirrored, matcher).solved


def test_hypotheses_are_confirmed_pyramids(random_db):
    matcher = _matcher(random_db)
    frame = next(_frames(random_db, 5, seed=71, noise_px=0.3))
    diag = MatchDiagnostics()
    first = next(iter(matcher.hypotheses(frame.obs, diag)))
    assert len(first.obs_index) == 4
    assert np.all(frame.truth_rows[first.obs_index] == first.cat_index)
    assert diag.pivots >= 3 and diag.candidates >= 1 and diag.extra["triples"] >= 1


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
    """The triples with the false star find no pyramid; a later triple solves the frame."""
    matcher = _matcher(hip_db)
    rng = np.random.default_rng(31)
    frame = next(_frames(hip_db, 3, seed=32, noise_px=0.3))
    obs, truth = _with_false_star(frame, 0, rng)
    solution = identify(obs, matcher)
    _assert_correct(solution, truth)
    assert solution.diagnostics.extra["triples"] > 1


def test_too_few_stars_is_a_clean_not_solved(random_db):
    matcher = _matcher(random_db)
    frame = next(_frames(random_db, 5, seed=41))
    for n in (0, 1, 2, 3):
        obs = Observation.from_pixels(frame.obs.x[:n], frame.obs.y[:n], frame.obs.camera, 0.1)
        solution = identify(obs, matcher)
        assert not solution.solved
        assert solution.rotation is None
    # Three real stars give a unique triangle, but nothing confirms it independently.
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
