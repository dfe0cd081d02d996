"""Pyramid: the mirror check, confirmed four-star pyramids, and a
false first star on the real sky (the contract every matcher meets is in
tests/matchers/test_matcher_contract.py)."""

from __future__ import annotations

import numpy as np
from synth import (
    assert_correct,
    first_hypothesis,
    frames,
    prepared_matcher,
    solved_past_false_star,
    with_false_star,
)

from startrack.match_records import MatchDiagnostics, Observation
from startrack.solver import identify

METHOD = "pyramid"


def test_mirrored_frame_gives_no_true_hypothesis(random_db):
    """A reflected image has every triangle's handedness reversed: Pyramid must not map it
    to the real stars, and nothing is solved."""
    matcher = prepared_matcher(METHOD, random_db)
    for frame in frames(random_db.catalog, random_db.camera, 6, seed=81):
        obs = frame.obs
        mirrored = Observation.from_pixels(obs.camera.width - 1 - obs.x, obs.y, obs.camera, 0.1)
        found = list(matcher.hypotheses(mirrored, MatchDiagnostics()))
        assert not any(np.array_equal(frame.truth_rows[h.obs_index], h.cat_index)
                       for h in found)
        assert not identify(mirrored, matcher).solved


def test_hypotheses_are_confirmed_pyramids(random_db):
    matcher = prepared_matcher(METHOD, random_db)
    first, diag = first_hypothesis(matcher, random_db)
    assert len(first.obs_index) == 4
    assert diag.pivots >= 3 and diag.candidates >= 1 and diag.extra["triples"] >= 1


def test_false_star_first_in_real_sky(hip_db):
    """The triples with the false star find no pyramid; a later triple solves the frame."""
    solution = solved_past_false_star(METHOD, hip_db)
    assert solution.diagnostics.extra["triples"] > 1


# --- pattern stars and the fallback ------------------------------------------------------


def test_pattern_pairs_are_the_pairs_among_pattern_stars(hip_db):
    from startrack.database import brighter_neighbours

    full = hip_db.pairs
    table = hip_db.pattern_pairs(10)
    assert hip_db.pattern_pairs(None) is full
    assert hip_db.pattern_pairs(10) is table  # built once per parameters
    assert 0 < len(table) < len(full) / 10
    assert np.all(np.diff(table.angle) >= 0)
    keep = brighter_neighbours(hip_db.vectors, np.radians(hip_db.camera.fov_deg / 2))
    want = (keep[full.i] < 10) & (keep[full.j] < 10)
    assert len(table) == int(want.sum())
    np.testing.assert_array_equal(table.i, full.i[want])
    # The k-vector answers the same windows as a plain scan.
    lo, hi = 0.05, 0.0512
    i, _, angle = table.query(lo, hi)
    assert len(i) == int(np.count_nonzero((table.angle >= lo) & (table.angle <= hi)))


def test_frame_without_pattern_stars_needs_the_fallback(hip_db):
    """Only faint stars in view (none of them a pattern star): the pattern-star pass finds
    nothing, the full pair table then solves the frame."""
    from startrack.database import brighter_neighbours

    cap = 5
    faint = brighter_neighbours(hip_db.vectors, np.radians(hip_db.camera.fov_deg / 2)) >= cap
    frame = next(frames(hip_db.catalog, hip_db.camera, 3, seed=44, noise_px=0.3))
    keep = faint[frame.truth_rows]
    obs = Observation.from_pixels(frame.obs.x[keep], frame.obs.y[keep], hip_db.camera, 0.3)
    truth = frame.truth_rows[keep]
    assert len(obs) >= 8
    without = prepared_matcher(METHOD, hip_db, pattern_per_region=cap, fallback=False)
    assert not identify(obs, without).solved
    solution = identify(obs, prepared_matcher(METHOD, hip_db, pattern_per_region=cap,
                                              fallback=True))
    assert_correct(solution, truth)
    assert solution.diagnostics.extra["fallback"]


def test_extra_stars_get_past_bright_false_stars(random_db):
    """The brightest ``max_stars`` are nearly all false: the fainter extra stars solve."""
    from startrack.matchers import MatcherConfig

    config = MatcherConfig(max_stars=5)
    rng = np.random.default_rng(45)
    frame = next(frames(random_db.catalog, random_db.camera, 3, seed=45, noise_px=0.1))
    obs, truth = frame.obs, frame.truth_rows
    for pos in (0, 0, 0):  # three false stars on top: two real stars left among five
        obs, truth = with_false_star(type(frame)(obs, truth, frame.rotation), pos, rng)
    assert not identify(obs, prepared_matcher(METHOD, random_db, config, extra_stars=0)).solved
    assert_correct(identify(obs, prepared_matcher(METHOD, random_db, config)), truth)


# --- shared verification: a wrong star pulling the attitude (belongs in test_verify.py) --


def test_verification_recovers_from_a_biased_hypothesis(hip_db):
    """A hypothesis with one star 6 px off, far from its three neighbours in the
    hypothesis, passes (the stars near the cluster confirm it) but tilts the attitude by
    ~15 arcmin; the refinement's wider capture must bring back the true attitude and every
    other star's identity."""
    from startrack.attitude import angle_between_deg
    from startrack.match_records import Hypothesis
    from startrack.verify import VerifyConfig, verify

    frame = list(frames(hip_db.catalog, hip_db.camera, 10, seed=5))[8]
    obs, truth = frame.obs, frame.truth_rows
    w = 1
    d = np.hypot(obs.x - obs.x[w], obs.y - obs.y[w])
    p = int(np.argmax(d))
    cluster = np.argsort(np.hypot(obs.x - obs.x[p], obs.y - obs.y[p]))[:5]
    cluster = cluster[cluster != w]
    x, y = obs.x.copy(), obs.y.copy()
    x[w] -= 6.0 * (obs.y[w] - obs.y[p]) / d[p]  # sideways: a turn about the cluster
    y[w] += 6.0 * (obs.x[w] - obs.x[p]) / d[p]
    moved = Observation.from_pixels(x, y, obs.camera, 0.3)
    stars = np.r_[cluster, w]
    result = verify(Hypothesis(stars, truth[stars]), moved, hip_db, VerifyConfig())
    assert result.accepted
    assert angle_between_deg(result.rotation, frame.rotation) * 3600 < 5.0
    assert len(result.obs_index) == len(obs) - 1 and w not in result.obs_index
    assert np.all(truth[result.obs_index] == result.cat_index)
