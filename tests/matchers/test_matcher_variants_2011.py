"""The 2011 paper's literal variants (angle_open, triangle_first, hybrid_single): each does
what the paper's text says, and the compiled triangle search pivots on the first triangle
when told to."""

from __future__ import annotations

import numpy as np
import pytest
from startrack._core.matchers.triangles import TriangleSearch
from synth import assert_correct, frames, prepared_matcher

from startrack.match_records import MatchDiagnostics
from startrack.matchers import MatcherConfig, available_methods, get_matcher
from startrack.matchers._shared.features import feature_sigma
from startrack.matchers._shared.triples import brightness_triples
from startrack.solver import identify

LITERAL = ["angle_open", "triangle_first", "hybrid_single"]


def test_literal_variants_are_registered_with_the_papers_settings(random_db):
    assert set(LITERAL) <= set(available_methods())
    angle = get_matcher("angle_open")(random_db)
    assert (angle.closing, angle.max_skips, angle.max_ambiguous, angle.max_chains) == (
        "none", 0, 1, 1)
    tri = get_matcher("triangle_first")(random_db)
    assert (tri.pivot_first, tri.min_stars, tri.max_ambiguous) == (True, 3, 1)
    hyb = get_matcher("hybrid_single")(random_db)
    assert (hyb.fourth_star, hyb.min_votes, hyb.unique, hyb.mirror_check,
            hyb.extra_stars) == (False, 1, True, False, 0)


@pytest.mark.parametrize("method", LITERAL)
def test_literal_variant_identifies_exact_frames(random_db, method):
    matcher = prepared_matcher(method, random_db)
    for frame in list(frames(random_db.catalog, random_db.camera, 4, seed=5))[:2]:
        assert_correct(identify(frame.obs, matcher), frame.truth_rows)


def _looked_up(first: bool, random_db):
    """The ordered triples the compiled search looked up, and its chain, on a frame where
    40-sigma windows leave many catalog triangles per observed one."""
    m = get_matcher("triangle")(random_db, MatcherConfig(tolerance_sigma=40.0))
    m.prepare()
    frame = next(frames(random_db.catalog, random_db.camera, 5, seed=71, noise_px=0.3))
    n = 8
    vec = frame.obs.vectors[:n]
    sigma = feature_sigma(frame.obs, 40.0, m.config.min_tolerance_rad)
    triples = np.array(brightness_triples(n), np.int64).reshape(-1, 3)
    search = TriangleSearch(m._catalog(), vec, triples, 40.0, 40.0 * np.sqrt(2.0) * sigma,
                            sigma)
    t, stars, rows = search.next_answer(0, 3, 1, first)
    looked = search.looked_up()
    return [tuple(triples[t])], looked, stars, rows, frame.truth_rows


def test_pivot_on_the_first_triangle_shares_two_of_its_stars(random_db):
    start, looked, stars, rows, truth = _looked_up(True, random_db)
    pivots = [tri for tri in looked if tri not in start]
    assert len(stars) >= 5 and len(pivots) >= 2, "the frame must need several pivots"
    assert all(tri[:2] == (stars[1], stars[2]) for tri in pivots)
    assert len(rows) == 1 and np.array_equal(truth[stars], rows[0])
    # ours walks along the chain: some pivot shares the newest two stars instead
    start, looked, stars, _, _ = _looked_up(False, random_db)
    assert any(tri[:2] != (stars[1], stars[2]) for tri in looked if tri not in start)


def test_single_pass_hybrid_yields_one_three_star_hypothesis_per_triangle(random_db):
    frame = next(frames(random_db.catalog, random_db.camera, 3, seed=4))
    diag = MatchDiagnostics()
    hyps = list(prepared_matcher("hybrid_single", random_db).hypotheses(frame.obs, diag))
    assert hyps and all(len(h.obs_index) == 3 for h in hyps)
    triples = [tuple(h.obs_index) for h in hyps]
    assert len(triples) == len(set(triples)), "one hypothesis per observed triangle"
    assert diag.extra["passes"] == 1 and diag.pivots == 0


def test_single_pass_hybrid_shortlists_what_any_angle_holds(random_db):
    """The paper gives no voting rule: a catalog star one lookup holds is a candidate, so
    the shortlists are those of the loosest vote (our passes ask for more votes)."""
    frame = next(frames(random_db.catalog, random_db.camera, 3, seed=4, noise_px=0.5))
    literal, ours = MatchDiagnostics(), MatchDiagnostics()
    list(prepared_matcher("hybrid_single", random_db).hypotheses(frame.obs, literal))
    first = prepared_matcher("hybrid", random_db)
    next(first.hypotheses(frame.obs, ours), None)  # ours' first pass: n - 1 votes
    assert sum(literal.extra["shortlist"]) > sum(ours.extra["shortlist"])


def test_single_pass_hybrid_answers_only_with_one_catalog_triangle(random_db):
    """Windows wide enough to hold several catalog triangles per observed one: the paper's
    hybrid, which does not pivot, has no answer; ours still ranks them."""
    frame = next(frames(random_db.catalog, random_db.camera, 3, seed=4))
    wide = MatcherConfig(tolerance_sigma=400.0)
    literal = prepared_matcher("hybrid_single", random_db, wide)
    ranked = get_matcher("hybrid")(random_db, wide, fourth_star=False, min_votes=1,
                                   mirror_check=False, max_per_triangle=1)
    ranked.prepare()
    assert list(ranked.hypotheses(frame.obs, MatchDiagnostics()))
    assert not list(literal.hypotheses(frame.obs, MatchDiagnostics()))


def test_the_papers_angle_chain_is_one_chain(random_db):
    """A false star as the brightest spot: the paper's one chain runs through it and ends
    indeterminate; ours tries other orderings and leaves it out."""
    from synth import false_star_first

    obs, truth = false_star_first(random_db)
    literal = MatchDiagnostics()
    assert not list(prepared_matcher("angle_open", random_db).hypotheses(obs, literal))
    assert literal.extra["chains"] == 1
    assert_correct(identify(obs, prepared_matcher("angle", random_db)), truth)


@pytest.mark.parametrize("method", ["angle", "angle_open"])
def test_the_angle_method_answers_from_two_stars(random_db, method):
    """Two stars whose angle matches one catalog pair: that pair, both ways round."""
    from synth import two_star_frame

    obs, rows = two_star_frame(random_db)
    hyps = list(prepared_matcher(method, random_db).hypotheses(obs, MatchDiagnostics()))
    assert [tuple(h.obs_index) for h in hyps] == [(0, 1), (0, 1)]
    assert {tuple(h.cat_index) for h in hyps} == {tuple(rows), tuple(rows[::-1])}
