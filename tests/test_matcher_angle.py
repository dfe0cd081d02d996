"""The angle method with pivoting: the joins, the triple order, the pivot chains (the
contract every matcher meets is in tests/test_matcher_contract.py)."""

from __future__ import annotations

import itertools

import numpy as np
from synth import assert_correct, false_star_first, frames, prepared_matcher

from startrack.identify import identify
from startrack.matchers.angle import PairCandidates, join_close, join_extend, smart_triples
from startrack.types import MatchDiagnostics

METHOD = "angle"


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


# --- pivot chains ----------------------------------------------------------------------


def test_false_star_first_in_real_sky(hip_db):
    """The chains that start with the false star die; a later ordering solves the frame."""
    obs, truth = false_star_first(hip_db)
    solution = identify(obs, prepared_matcher(METHOD, hip_db))
    assert_correct(solution, truth)
    assert solution.diagnostics.extra["chains"] > 1


def test_pivot_diagnostics_are_counted(random_db):
    matcher = prepared_matcher(METHOD, random_db)
    frame = next(frames(random_db.catalog, random_db.camera, 5, seed=71, noise_px=0.3))
    diag = MatchDiagnostics()
    first = next(iter(matcher.hypotheses(frame.obs, diag)))
    assert len(first.obs_index) >= 3
    assert np.all(frame.truth_rows[first.obs_index] == first.cat_index)
    assert diag.pivots >= 1 and diag.candidates >= 1
    assert diag.extra["lookups"] <= 28
