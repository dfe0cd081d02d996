"""An approximate or unknown field of view (startrack.solver._fov_search, the quad matcher and its
tables)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from repo_paths import DATA
from scipy.spatial.transform import Rotation
from startrack._core.database.quad_table import pattern_keys

from startrack.attitude import random_attitudes
from startrack.camera import Camera, stars_in_view
from startrack.centroids import Centroids
from startrack.database import _quads as Q
from startrack.outputs import frame_record
from startrack.sky import SkySpec, load_sky
from startrack.solver._fov_fit import fit_focal
from startrack.solver._fov_search import BlindSolver, focal_range
from startrack.solver._fov_windows import windows
from startrack.solver._pipeline import FrameInput, Options, Pipeline
from tests.matchers.quad_reference import edge_angles

SKY = SkySpec(kind="random")  # what --sky random gives: 2000 stars, ~19 in a 20 deg frame
# A right answer is within a pixel (70 arcsec at 20 deg over 1024 px); a wrong one is off by
# degrees.
CAMERA = Camera.from_fov(1024, 1024, 20.0)


def _frames(camera: Camera, n: int, seed: int, noise_px: float = 0.3):
    """Centroid inputs of the test sky at seeded attitudes, with the truth."""
    catalog = load_sky(SKY)
    rng = np.random.default_rng(seed)
    out = []
    for rot in random_attitudes(n, rng):
        rows, x, y = stars_in_view(catalog, camera, rot)
        x = x + rng.normal(0, noise_px, len(x))
        y = y + rng.normal(0, noise_px, len(y))
        flux = np.arange(len(x), 0, -1, dtype=float)  # catalog order: brightest first
        out.append((FrameInput("sim", Centroids(x, y, flux)), rows, rot))
    return out


def _boresight_error_arcsec(a: Rotation, b: Rotation) -> float:
    ba, bb = a.apply([0, 0, 1.0]), b.apply([0, 0, 1.0])
    return math.degrees(math.acos(min(1.0, float(ba @ bb)))) * 3600.0


def test_pattern_keys_ignore_scale_and_rotation():
    rng = np.random.default_rng(1)
    v = rng.normal([0, 0, 50], 1.0, (4, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    quad = np.arange(4)[None]
    rot = Rotation.from_euler("xyz", [10, 40, 70], degrees=True)
    keys = [pattern_keys(np.ascontiguousarray(w), quad, Q.EDGES, Q.BIN, Q.NBINS,
                         float(Q.RATIO_STEPS)) for w in (v, rot.apply(v))]
    assert keys[0][0][0] == keys[1][0][0]
    np.testing.assert_array_equal(keys[0][1], keys[1][1])
    # the same shape at another scale: the four stars spread twice as wide
    centre = v.mean(axis=0) / np.linalg.norm(v.mean(axis=0))
    wide = centre + 2.0 * (v - centre)
    wide /= np.linalg.norm(wide, axis=1, keepdims=True)
    ratios = pattern_keys(np.ascontiguousarray(wide), quad, Q.EDGES, Q.BIN, Q.NBINS,
                          float(Q.RATIO_STEPS))[1]
    assert np.abs(ratios.astype(int) - keys[0][1].astype(int)).max() <= 2


def test_all_quads_is_every_four_within_the_edge():
    rng = np.random.default_rng(2)
    v = rng.normal([0, 0, 20], 2.0, (40, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    max_edge = 0.04
    angles = np.arccos(np.clip(v @ v.T, -1, 1))
    higher = np.triu(angles <= max_edge, k=1).sum(axis=1)
    assert higher.max() <= Q.MAX_HIGHER  # so the per-star cap leaves nothing out
    found = {tuple(q) for q in Q.all_quads(v, max_edge).tolist()}
    import itertools

    combos = np.array(list(itertools.combinations(range(len(v)), 4)))
    within = edge_angles(v, combos).max(axis=1) <= max_edge
    brute = {tuple(q) for q in combos[within].tolist()}
    assert found == brute and len(found) >= 3


def test_fit_focal_recovers_the_focal_length():
    rng = np.random.default_rng(4)
    true = Camera.from_fov(1024, 768, 11.42)
    rot = Rotation.random(random_state=5)
    x, y = rng.uniform(0, 1023, 30), rng.uniform(0, 767, 30)
    sky = rot.apply(true.pixel_to_vector(x, y))
    guess = dataclasses.replace(true, f_px=true.f_px * 1.06)
    f = fit_focal(guess, x, y, sky)
    assert f == pytest.approx(true.f_px, rel=1e-6)


def test_windows_cover_the_range_in_steps():
    w = windows(100.0, 300.0, step=1.2)
    assert w[0][0] == pytest.approx(100.0) and w[-1][1] == pytest.approx(300.0)
    assert all(b / a <= 1.2 + 1e-9 for a, b in w)
    lo, hi = focal_range(CAMERA, 0.1)
    assert lo < CAMERA.f_px < hi


@pytest.mark.parametrize("error", [-0.08, -0.03, 0.0, 0.05, 0.09])
def test_fov_within_the_tolerance_solves_and_is_fitted(error):
    """Simulated frames of a 20 deg camera, solved from a nominal FOV off by ``error``."""
    pipeline = Pipeline(Options(fov_deg=CAMERA.fov_deg * (1 + error), size=(1024, 1024),
                                sky="random", method="quad", fov_tolerance=0.1))
    for frame, _, rot in _frames(CAMERA, 3, seed=10):
        result = pipeline.solve(frame)
        assert result.solution.solved
        assert _boresight_error_arcsec(result.solution.rotation, rot) < 60.0
        assert result.camera.fov_deg == pytest.approx(CAMERA.fov_deg, abs=0.01)
        assert frame_record(result)["fov_deg"] == pytest.approx(CAMERA.fov_deg, abs=0.01)


@pytest.mark.parametrize("error", [0.0, 0.01])
def test_an_exact_camera_is_reported_as_given_unless_the_data_reject_it(error):
    """A nominal pinhole camera that is exactly right is reported as given (not a focal
    length and a k1 fitted a few parts in 1e4 off, as if measured); one 1% off (5 px at
    the edge) is rejected by the data and fitted."""
    pipeline = Pipeline(Options(fov_deg=CAMERA.fov_deg * (1 + error), size=(1024, 1024),
                                sky="random", fov_tolerance=0.1))
    for frame, _, rot in _frames(CAMERA, 3, seed=11):
        result = pipeline.solve(frame)
        assert result.solution.solved
        assert _boresight_error_arcsec(result.solution.rotation, rot) < 60.0
        if error == 0.0:
            assert result.camera == pipeline.setup_for(frame)[0]
            assert frame_record(result)["fov_deg"] == CAMERA.fov_deg
        else:  # fitted, its k1 trading a little against the focal length
            assert result.camera.fov_deg == pytest.approx(CAMERA.fov_deg, abs=0.03)


@pytest.mark.parametrize("method", ["pyramid", "quad"])
def test_a_right_nominal_fov_answers_through_the_nominal_camera(method, monkeypatch):
    """A nominal FOV that is right: the answer is made through the nominal camera and
    stands as it is (no fit-and-verify rounds, no second verification). The quad search
    answers first whatever the configured method (issue 43: scale-free, it pays nothing
    for the nominal FOV's error, and its answer stands through the nominal camera);
    its stars are the true ones, its attitude the exact FOV's own to arcseconds."""
    from startrack.solver import _fov_given, _fov_search

    nominal = Pipeline(Options(fov_deg=CAMERA.fov_deg, size=(1024, 1024), sky="random",
                               method=method, fov_tolerance=0.1))
    exact = Pipeline(Options(fov_deg=CAMERA.fov_deg, size=(1024, 1024), sky="random",
                             method=method, fov_tolerance=0.0))
    truth_ids = load_sky(SKY).ids
    nominal.solve(_frames(CAMERA, 1, seed=20)[0][0])  # warmed: its tables and kernels
    rounds = []
    verify_fitted = _fov_search.verify_fitted
    monkeypatch.setattr(_fov_search, "verify_fitted",
                        lambda *a, **k: rounds.append(1) or verify_fitted(*a, **k))
    for frame, rows, rot in _frames(CAMERA, 6, seed=21):
        got, want = nominal.solve(frame), exact.solve(frame)
        sol = got.solution
        assert sol.solved and got.camera == exact.setup_for(frame)[0]
        assert sol.method == "quad" and [s["stage"] for s in got.steps] == ["FOV search"]
        assert _boresight_error_arcsec(sol.rotation, rot) < 60.0
        # the same frame's two verified answers: their labelled stars may differ by one
        assert _boresight_error_arcsec(sol.rotation, want.solution.rotation) < 5.0
        assert np.array_equal(truth_ids[rows[sol.obs_index]], got.catalog.ids[sol.cat_index])
    assert not rounds  # every answer stood through the nominal camera
    # the rule: the right camera stands on its stars, one 1% off does not
    frame, rows, _ = _frames(CAMERA, 1, seed=22)[0]
    catalog = load_sky(SKY)
    x, y = frame.centroids.x, frame.centroids.y
    assert _fov_given.given_stands(CAMERA, x, y, np.arange(len(x)), catalog.vectors[rows])
    assert not _fov_given.given_stands(CAMERA.with_focal(CAMERA.f_px * 1.01), x, y,
                                       np.arange(len(x)), catalog.vectors[rows])


def test_fov_outside_the_tolerance_is_not_solved_never_wrong():
    pipeline = Pipeline(Options(fov_deg=CAMERA.fov_deg * 1.3, size=(1024, 1024),
                                sky="random", method="quad", fov_tolerance=0.05))
    for frame, _, rot in _frames(CAMERA, 3, seed=11):
        result = pipeline.solve(frame)
        if result.solution.solved:  # only ever right
            assert _boresight_error_arcsec(result.solution.rotation, rot) < 60.0
        else:
            assert result.solution.reason == "no_match"


@pytest.fixture(scope="module")
def blind():
    catalog = load_sky(SKY)
    return BlindSolver(catalog, SKY, 0.5, fov_range=(14.0, 34.0))


@pytest.mark.parametrize("fov", [17.0, 24.0, 31.0])
def test_blind_search_finds_pointing_and_fov(blind, fov):
    camera = Camera.from_fov(1024, 1024, fov)
    for frame, _, rot in _frames(camera, 2, seed=int(fov)):
        result = blind.solve(frame.centroids.x, frame.centroids.y, (1024, 1024))
        assert result.solution.solved
        assert _boresight_error_arcsec(result.solution.rotation, rot) < 60.0
        assert result.camera.fov_deg == pytest.approx(fov, abs=0.02)


def test_blind_junk_and_too_few_are_not_solved(blind):
    rng = np.random.default_rng(9)
    junk = FrameInput("junk", Centroids(rng.uniform(0, 1023, 40), rng.uniform(0, 1023, 40),
                                        np.arange(40, 0, -1.0)))
    result = blind.solve(junk.centroids.x, junk.centroids.y, (1024, 1024))
    assert not result.solution.solved and result.solution.reason == "no_match"
    few = FrameInput("few", Centroids(np.array([1.0, 5.0]), np.array([2.0, 9.0]),
                                      np.array([2.0, 1.0])))
    few_result = blind.solve(few.centroids.x, few.centroids.y, (1024, 1024))
    assert few_result.solution.reason == "too_few_stars"


def test_no_fov_for_a_centroid_list_needs_the_size():
    from startrack.errors import InputError

    frame, _, _ = _frames(CAMERA, 1, seed=12)[0]
    with pytest.raises(InputError, match="--size"):
        Pipeline(Options(sky="random")).solve(frame)


REAL_FRAME = DATA / "realsky_azi45.png"
AZI45 = (355.2046, 58.1518)  # tetra3's pointing (shared/real-sky/README.md), true FOV 11.42


def _off_arcsec(result) -> float:
    from startrack.sky import radec_to_vectors

    a = radec_to_vectors(np.array([result.ra_deg]), np.array([result.dec_deg]))[0]
    b = radec_to_vectors(np.array([AZI45[0]]), np.array([AZI45[1]]))[0]
    return math.degrees(math.acos(min(1.0, float(a @ b)))) * 3600.0


@pytest.mark.parametrize("nominal", [11.0, 12.0])
def test_real_frame_solves_from_a_nominal_fov(nominal):
    import startrack

    result = startrack.solve(REAL_FRAME, fov_deg=nominal, epoch=2019.6)
    assert result.solved and _off_arcsec(result) < 30.0
    assert result.fov_deg == pytest.approx(11.42, abs=0.02)
    assert result.to_dict()["fov_deg"] == pytest.approx(result.fov_deg)


@pytest.mark.slow
def test_real_frame_solves_with_no_fov():
    """Builds the gaia sky's pattern tables for 1 to 40 deg on a fresh cache: minutes."""
    import startrack

    result = startrack.solve(REAL_FRAME, epoch=2019.6)
    assert result.solved and _off_arcsec(result) < 30.0
    assert result.fov_deg == pytest.approx(11.42, abs=0.02)


@pytest.mark.parametrize("method", ["quad", "pyramid"])
def test_the_focal_length_search_goes_first_whatever_the_method(monkeypatch, method):
    """With a nominal FOV (2% off), the scale-free search answers first, whatever the
    configured method (issue 43: the nominal FOV's error costs it nothing); the
    configured method is not tried where it answers."""
    from startrack.solver._identifier import Identifier

    tries = []
    solve = Identifier.solve
    monkeypatch.setattr(Identifier, "solve",
                        lambda self, *a, **k: tries.append(1) or solve(self, *a, **k))
    pipeline = Pipeline(Options(fov_deg=CAMERA.fov_deg * 1.02, size=(1024, 1024),
                                sky="random", method=method, fov_tolerance=0.1))
    for frame, _, rot in _frames(CAMERA, 3, seed=12):
        result = pipeline.solve(frame)
        assert result.solution.solved and result.solution.method == "quad"
        assert _boresight_error_arcsec(result.solution.rotation, rot) < 60.0
        assert result.camera.fov_deg == pytest.approx(CAMERA.fov_deg, abs=0.02)
    # pyramid's identifier is loaded and warmed once (a throwaway frame), never tried
    assert len(tries) == (1 if method == "pyramid" else 0)


def test_where_the_search_finds_nothing_the_first_look_takes_the_brightest_stars(monkeypatch):
    """Where the focal-length search finds nothing (forced here), the configured method
    is tried on its FIRST_LOOK_STARS brightest stars, no fainter ones: where the FOV is
    right it answers (as pyramid); where it is 5% off it tries at most that many stars'
    triples and answers nothing."""
    from startrack.match_records import Solution
    from startrack.matchers._pyramid import PyramidMatcher
    from startrack.solver import _nominal
    from startrack.solver._identifier import FIRST_LOOK_STARS, Identifier

    search = _nominal.solve_approximate
    monkeypatch.setattr(_nominal, "solve_approximate", lambda *a, **k: dataclasses.replace(
        search(*a, **k), solution=Solution(False, "quad", reason="no_match")))
    looks = []
    identify = Identifier.identify
    monkeypatch.setattr(Identifier, "identify", lambda self, obs, deadline=None,
                        first_look=False: looks.append(
                            (first_look, identify(self, obs, deadline, first_look)))
                        or looks[-1][1])
    for error, solved in ((0.0, True), (0.05, False)):
        pipeline = Pipeline(Options(fov_deg=CAMERA.fov_deg * (1 + error), size=(1024, 1024),
                                    sky="random", fov_tolerance=0.1))
        looks.clear()
        for frame, _, rot in _frames(CAMERA, 3, seed=13):
            result = pipeline.solve(frame)
            assert result.solution.solved == solved
            if solved:
                assert result.solution.method == "pyramid"
                assert _boresight_error_arcsec(result.solution.rotation, rot) < 60.0
        firsts = [sol for first, sol in looks if first]  # the others: the warm-up's
        n = FIRST_LOOK_STARS
        assert len(firsts) >= 3 and all(
            sol.diagnostics.extra["triples"] <= n * (n - 1) * (n - 2) // 6 for sol in firsts)
        (nominal,) = [i for i in pipeline._identifiers.values() if i.matcher.name == "pyramid"]
        look = nominal.first_look
        assert isinstance(look, PyramidMatcher) and look.database is nominal.database
        assert (look.config.max_stars, look.extra_stars) == (FIRST_LOOK_STARS, 0)
