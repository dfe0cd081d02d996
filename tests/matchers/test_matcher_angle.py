"""The angle method with pivoting: the pivot chains (the joins and triple orders are in
tests/matchers/test_matching.py, the contract every matcher meets in
tests/matchers/test_matcher_contract.py)."""

from __future__ import annotations

from synth import (
    assert_correct,
    false_stars_first,
    first_hypothesis,
    prepared_matcher,
    solved_past_false_star,
)

from startrack.solver import identify

METHOD = "angle"


# --- pivot chains ----------------------------------------------------------------------


def test_false_star_first_in_real_sky(hip_db):
    """The chains that start with the false star die; a later ordering solves the frame."""
    solution = solved_past_false_star(METHOD, hip_db)
    assert solution.diagnostics.extra["chains"] > 1


def test_pivot_diagnostics_are_counted(random_db):
    matcher = prepared_matcher(METHOD, random_db)
    first, diag = first_hypothesis(matcher, random_db)
    assert len(first.obs_index) >= 3
    assert diag.pivots >= 1 and diag.candidates >= 1
    assert diag.extra["lookups"] <= 28


def test_fainter_stars_join_when_false_stars_crowd_the_brightest(hip_db):
    """Six false stars among the eight brightest: the chains of the brightest cannot
    solve; those that start with the extra, fainter stars do."""
    obs, truth = false_stars_first(hip_db, 6)
    assert not identify(obs, prepared_matcher(METHOD, hip_db, extra_stars=0)).solved
    solution = identify(obs, prepared_matcher(METHOD, hip_db))
    assert_correct(solution, truth)
    assert solution.diagnostics.extra["chains"] > 56  # past the triples of the brightest


def test_full_catalog_lookups_give_the_same_answer(hip_db):
    """pattern_per_region=None looks pairs up among every catalog star (the slow way)."""
    solved_past_false_star(METHOD, hip_db, pattern_per_region=None)
