"""The hybrid matcher: angle shortlists and votes, the triangle confirmation over them,
passes, and fourth-star checks counted as pivots (the contract every matcher meets is in
tests/matchers/test_matcher_contract.py)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from synth import (
    assert_correct,
    false_stars_first,
    frames,
    prepared_matcher,
    with_false_star,
)

from startrack.attitude import angle_between_deg
from startrack.match_records import MatchDiagnostics
from startrack.matchers import get_matcher
from startrack.matchers._hybrid import angle_votes
from startrack.solver import identify

METHOD = "hybrid"


@pytest.fixture(scope="module")
def matcher(random_db):
    return prepared_matcher(METHOD, random_db)


@pytest.mark.slow
def test_real_sky_with_false_stars(hip_db):
    """Hipparcos: the shortlists hold hundreds of stars, the confirmation keeps it right."""
    m = prepared_matcher(METHOD, hip_db)
    for frame in frames(hip_db.catalog, hip_db.camera, 5, seed=22, noise_px=0.3,
                        false_stars=2):
        solution = identify(frame.obs, m)
        assert solution.solved
        assert angle_between_deg(solution.rotation, frame.rotation) * 3600 < 120.0


def test_shortlists_hold_the_true_star_and_are_small(random_db):
    frame = next(frames(random_db.catalog, random_db.camera, 5, seed=81, noise_px=0.3))
    n = 8
    m = get_matcher(METHOD)(random_db)
    diag = MatchDiagnostics()
    tol = m.angle_tolerance(frame.obs)
    vectors = frame.obs.vectors[:n]
    votes, windows = angle_votes(vectors, random_db, tol, diag)
    assert votes.shape == (n, len(random_db.vectors)) and diag.candidates > 0
    truth = frame.truth_rows[:n]
    assert np.all(votes[np.arange(n), truth] == n - 1)  # every pair votes for the truth
    assert np.all((votes >= n - 1).sum(axis=1) <= 20)  # out of 2000 catalog stars
    # Votes are counts of lookups: recount them by brute force over the k-vector lookups.
    table = random_db.pairs
    want = np.zeros_like(votes, dtype=int)
    for a, b in itertools.combinations(range(n), 2):
        theta = np.arccos(np.clip(vectors[a] @ vectors[b], -1, 1))
        i, j, _ = table.query(theta - tol, theta + tol)
        assert (windows[a, b, 1] - windows[a, b, 0]) == len(i)
        assert np.array_equal(table.i[windows[a, b, 0]:windows[a, b, 1]], i)
        stars = np.unique(np.concatenate([i, j]))
        want[a, stars] += 1
        want[b, stars] += 1
    assert np.array_equal(votes, want)


def test_fourth_star_checks_are_pivots_and_a_false_star_costs_a_pass(random_db, matcher):
    frame = next(frames(random_db.catalog, random_db.camera, 5, seed=83, noise_px=0.3))
    obs, truth = with_false_star(frame, 1, np.random.default_rng(84))
    solution = identify(obs, matcher)
    assert_correct(solution, truth)
    diag = solution.diagnostics
    assert diag.pivots >= 1  # the fourth-star check, as Pyramid counts its confirming star
    # The false star spoils one vote of every true star: the pass that asks for all of
    # them fails, and a later one succeeds.
    assert diag.extra["passes"] >= 2
    assert len(solution.obs_index) == np.count_nonzero(truth >= 0)


def test_a_second_round_on_fainter_stars_when_false_stars_crowd_the_brightest(hip_db):
    obs, truth = false_stars_first(hip_db, 6)
    assert not identify(obs, prepared_matcher(METHOD, hip_db, extra_stars=0)).solved
    solution = identify(obs, prepared_matcher(METHOD, hip_db))
    assert_correct(solution, truth)
    # The first round's passes all failed: the second one (12 stars) solved it.
    assert solution.diagnostics.extra["passes"] > 4
    assert max(solution.obs_index) >= 8
