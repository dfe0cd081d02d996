"""The compiled quad search of one window (``_core.matchers.quad.match_window``) against the numpy
search it replaced (tests/matchers/quad_reference.py): the same candidates in the same order, with
the same scales and errors, on seeded noisy frames with false and missing stars."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from startrack._core.matchers.quad import QuadRules, image_quads, image_quads_by_faintest

from startrack.camera import Camera, stars_in_view
from startrack.database import StarDatabase
from startrack.database import _quads as Q
from startrack.matchers._quad import RULES, confirmations, match_patterns
from startrack.sky import SkySpec, load_sky
from tests.matchers.quad_reference import confirm_counts, image_patterns, match_quads


@pytest.fixture(scope="module")
def sky():
    return load_sky(SkySpec(kind="random", n_stars=6000, seed=7))


@pytest.fixture(scope="module")
def levels(sky):
    return {deg: Q.QuadLevel(deg, Q.build_level_arrays(sky.vectors, deg))
            for deg in (Q.level_for(16.0), Q.level_for(16.0 / Q.LEVEL_STEP))}


def _frame(sky, camera: Camera, seed: int) -> np.ndarray:
    """Unit vectors of a noisy frame: 10% of the stars missing, 3 false stars at random
    brightness ranks, 0.3 px centroid noise, brightest first."""
    rng = np.random.default_rng(seed)
    rot = Rotation.from_quat(rng.normal(size=4))
    _, x, y = stars_in_view(sky, camera, rot)
    keep = rng.random(len(x)) >= 0.1
    x, y = x[keep] + rng.normal(0, 0.3, keep.sum()), y[keep] + rng.normal(0, 0.3, keep.sum())
    for _ in range(3):
        at = int(rng.integers(0, len(x) + 1))
        x = np.insert(x, at, rng.uniform(0, camera.width))
        y = np.insert(y, at, rng.uniform(0, camera.height))
    return camera.pixel_to_vector(x, y)


@pytest.mark.parametrize("seed", range(12))
def test_the_compiled_window_search_is_the_numpy_one(sky, levels, seed):
    camera = Camera.from_fov(1024, 1024, 16.0 * (1.0 + 0.02 * (seed % 3 - 1)))
    vectors = _frame(sky, camera, seed)
    for deg, level in levels.items():
        slack = 1.05 if seed % 2 else 1.3
        got = match_patterns(vectors, level, sky.vectors, slack)
        quads, edges = image_patterns(vectors, deg, slack)
        want = match_quads(quads, edges, level, sky.vectors)
        for g, w in zip(got, want, strict=True):
            assert g.dtype == w.dtype and np.array_equal(g, w)
    assert len(got[0]) > 0


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("level_deg, slack", [(16.0, 1.0), (16.0, 1.05), (4.0, 1.3)])
def test_the_image_patterns_follow_the_table_builders_rule(sky, seed, level_deg, slack):
    """A frame seen at its own level, and at a level so narrow that its stars are sparse
    (their patterns reach out to their nearest stars)."""
    vectors = _frame(sky, Camera.from_fov(1024, 1024, 16.0), seed)
    size = np.radians(level_deg) * slack
    got = image_quads(RULES, vectors, Q.PATTERN_SIZE * size, Q.MAX_PATTERN_SIZE * size)
    want = image_patterns(vectors, level_deg, slack)
    assert len(want[0]) > 0
    for g, w in zip(got, want, strict=True):
        assert np.array_equal(g, w)


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("level_deg, slack", [(16.0, 1.0), (16.0, 1.05), (4.0, 1.3)])
def test_the_fast_paths_patterns_made_one_faintest_star_at_a_time_are_all_of_them(
        sky, seed, level_deg, slack):
    """The fast path makes each faintest star's patterns only when the brighter stars'
    found nothing: the same patterns and edges, in the order of a stable sort of all of
    them by their faintest star (the order it looked them up in when it made them all)."""
    vectors = _frame(sky, Camera.from_fov(1024, 1024, 16.0), seed)
    size = np.radians(level_deg) * slack
    bounds = (Q.PATTERN_SIZE * size, Q.MAX_PATTERN_SIZE * size)
    quads, edges = image_quads(RULES, vectors, *bounds)
    by = np.argsort(quads[:, 3], kind="stable")
    got_quads, got_edges = image_quads_by_faintest(RULES, vectors, *bounds)
    assert len(quads) > 4 and not np.array_equal(by, np.arange(len(quads)))
    assert np.array_equal(got_quads, quads[by]) and np.array_equal(got_edges, edges[by])
    apart = np.array([[1.0, 0, 0], [0, 1, 0], [0, 0, 1], [-1, 0, 0]])
    for few in (vectors[:3], apart):  # too few stars; no pair within reach
        none_quads, none_edges = image_quads_by_faintest(RULES, few, *bounds)
        assert none_quads.shape == (0, 4) and none_edges.shape == (0, 6)


def test_no_patterns_and_an_empty_table_give_no_candidates(sky, levels):
    level = next(iter(levels.values()))
    none = match_patterns(sky.vectors[:3], level, sky.vectors, 1.05)
    empty = Q.QuadLevel(level.level_deg, {"keys": np.zeros(0, np.int32),
                                          "quads": np.zeros((0, 4), np.int32),
                                          "ratios": np.zeros((0, 5), np.uint8)})
    camera = Camera.from_fov(1024, 1024, 16.0)
    vectors = _frame(sky, camera, 1)
    for obs_q, cat_q, scale, error in (none, match_patterns(vectors, empty, sky.vectors, 1.05)):
        assert obs_q.shape == (0, 4) and cat_q.shape == (0, 4)
        assert len(scale) == 0 and len(error) == 0


@pytest.mark.parametrize("seed", range(6))
def test_the_compiled_confirmation_count_is_the_numpy_one(sky, levels, seed):
    """Every candidate of a window (true ones confirm many stars, false ones few), counted
    in one compiled call, as the batched numpy count did; a row the checked catalog lacks
    gives -1."""
    camera = Camera.from_fov(1024, 1024, 16.0)
    rng = np.random.default_rng(seed)
    _, x, y = stars_in_view(sky, camera, Rotation.from_quat(rng.normal(size=4)))
    x, y = x + rng.normal(0, 0.3, len(x)), y + rng.normal(0, 0.3, len(y))
    level = levels[Q.level_for(16.0)]
    obs_q, cat_q, scale, _ = match_patterns(camera.pixel_to_vector(x, y), level,
                                            sky.vectors, 1.05)
    f = camera.f_px * scale
    db = StarDatabase(sky, camera)
    got = confirmations(x, y, camera, obs_q, cat_q, f, db)
    want = confirm_counts(x, y, camera, obs_q, cat_q, f, sky.vectors)
    assert len(got) > 10 and np.array_equal(got, want)
    assert got.max() >= 10 and got.min() <= 1  # the true pattern and coincidences
    cut = np.zeros(len(cat_q), bool)
    cut[::3] = True
    cat_cut = np.where(cut[:, None], len(db.vectors) + cat_q, cat_q)
    marked = confirmations(x, y, camera, obs_q, cat_cut, f, db)
    assert np.all(marked[cut] == -1) and np.array_equal(marked[~cut], want[~cut])


@pytest.mark.parametrize("seed", range(4))
def test_the_first_strong_candidate_is_true_and_one_the_ranking_holds(sky, seed):
    """On a true frame the fast path's candidate names the true stars and is one of the
    full ranking's candidates, with the same focal length, error and count (to rounding); on random
    points it finds nothing (then the ranking runs)."""
    from startrack.match_records import MatchDiagnostics
    from startrack.matchers._quad import STRONG_CONFIRMED, QuadMatcher

    camera = Camera.from_fov(1024, 1024, 16.0)
    db = StarDatabase(sky, camera)
    matcher = QuadMatcher(db)
    rng = np.random.default_rng(seed)
    rows, x, y = stars_in_view(sky, camera, Rotation.from_quat(rng.normal(size=4)))
    x, y = x + rng.normal(0, 0.3, len(x)), y + rng.normal(0, 0.3, len(y))
    lo, hi = camera.f_px / 1.03, camera.f_px * 1.03
    strong = matcher.strong(x, y, camera, lo, hi, MatchDiagnostics())
    assert strong is not None and strong.confirmed >= STRONG_CONFIRMED
    assert np.array_equal(rows[strong.hypothesis.obs_index], strong.hypothesis.cat_index)
    ranked = matcher.scaled(x, y, camera, lo, hi, MatchDiagnostics())
    same = [h for h in ranked
            if np.array_equal(h.hypothesis.obs_index, strong.hypothesis.obs_index)
            and np.array_equal(h.hypothesis.cat_index, strong.hypothesis.cat_index)]
    assert len(same) == 1
    assert same[0].confirmed == strong.confirmed  # edges by libm's asin: within an ulp
    assert same[0].f_px == pytest.approx(strong.f_px, rel=1e-12)
    assert same[0].error == pytest.approx(strong.error, rel=1e-9, abs=1e-12)
    junk_x, junk_y = rng.uniform(0, 1024, 40), rng.uniform(0, 1024, 40)
    assert matcher.strong(junk_x, junk_y, camera, lo, hi, MatchDiagnostics()) is None


def test_a_matcher_remembering_its_windows_answers_as_a_fresh_one(sky):
    """The camera and level of each window are remembered per camera object: two cameras
    of different width asked in turn (and windows of both sizes) get what a fresh matcher
    gives each."""
    from startrack.match_records import MatchDiagnostics
    from startrack.matchers._quad import QuadMatcher

    narrow, wide = Camera.from_fov(1024, 1024, 16.0), Camera.from_fov(1200, 1024, 16.0)
    db = StarDatabase(sky, narrow)
    kept = QuadMatcher(db)
    rng = np.random.default_rng(3)
    _, x, y = stars_in_view(sky, narrow, Rotation.from_quat(rng.normal(size=4)))
    found = []
    for camera in (narrow, wide, narrow, wide):
        for scale in (1.0, 1.03):
            lo, hi = narrow.f_px * scale / 1.03, narrow.f_px * scale * 1.03
            got = kept.strong(x, y, camera, lo, hi, MatchDiagnostics())
            want = QuadMatcher(db).strong(x, y, camera, lo, hi, MatchDiagnostics())
            assert (got is None) == (want is None)
            if got is not None:
                found.append(camera is narrow)
                assert np.array_equal(got.hypothesis.cat_index, want.hypothesis.cat_index)
                assert (got.f_px, got.error, got.confirmed) == (want.f_px, want.error,
                                                                want.confirmed)
    assert any(found) and not all(found)  # both cameras' windows found a candidate


@pytest.mark.parametrize("bin_width", [0.0, -0.025])
def test_rules_with_no_positive_key_bin_are_refused(bin_width):
    """The key bins are found by dividing by the bin width, so a zero or negative one is
    an error when the rules are made, not a wrong lookup later."""
    with pytest.raises(ValueError, match="bin"):
        QuadRules(tolerance=0.012, bin=bin_width, nbins=40, near=0.014, ratio_unit=1 / 255,
                  max_candidates=10, image_stars=16, image_nearest=10, edges=Q.EDGES,
                  perms=np.zeros((24, 4)), perm_edges=np.zeros((24, 6)))
