"""The paper-literal variants: each differs from its method in the one way it says, and
still identifies exact frames through verification."""

from __future__ import annotations

import numpy as np
import pytest
from synth import assert_correct, frames, prepared_matcher, with_false_star

from startrack.bench._raw import pairs_off
from startrack.match_records import MatchDiagnostics
from startrack.matchers import available_methods
from startrack.matchers._radial import field_rings, pair_triangles
from startrack.matchers._shared.geometry import angle_table
from startrack.solver import identify

VARIANTS = ["angle_closed", "angle_open", "triangle_nopivot", "hybrid_nofourth",
            "radial_noise", "sss"]


def _first_hypotheses(matcher, obs, limit=20):
    out = []
    for hyp in matcher.hypotheses(obs, MatchDiagnostics()):
        out.append(hyp)
        if len(out) >= limit:
            break
    return out


def test_variants_are_registered():
    assert set(VARIANTS) | {"radial_paper", "radial_patch"} <= set(available_methods())


# radial_paper is left out: over a whole random sky the paper's coarse rings do not
# single out a star (it worked within a known patch: test_known_patch_... below).
@pytest.mark.parametrize("method", VARIANTS)
def test_variant_identifies_exact_frames(random_db, method):
    matcher = prepared_matcher(method, random_db)
    for frame in list(frames(random_db.catalog, random_db.camera, 4, seed=5))[:2]:
        assert_correct(identify(frame.obs, matcher), frame.truth_rows)


def test_every_closing_angle_checked_leaves_no_pair_off(random_db):
    """With closing="all" every pair of a hypothesis was looked up, so none misses the
    catalog angle; the default and the open chain may leave one unchecked."""
    closed = prepared_matcher("angle_closed", random_db)
    tol_hits = {"angle_closed": 0, "angle_open": 0}
    rng = np.random.default_rng(3)
    for frame in list(frames(random_db.catalog, random_db.camera, 12, seed=9))[:8]:
        obs, _ = with_false_star(frame, 1, rng)
        for name in tol_hits:
            # the open chain's rule on every ordering (the paper's one chain ends at the
            # false star)
            m = closed if name == "angle_closed" else prepared_matcher(
                name, random_db, max_chains=220)
            for hyp in _first_hypotheses(m, obs):
                tol_hits[name] += pairs_off(obs.vectors[hyp.obs_index],
                                            random_db.vectors[hyp.cat_index],
                                            m.angle_tolerance(obs))
    assert tol_hits["angle_closed"] == 0
    assert tol_hits["angle_open"] > 0


def test_no_forced_pivot_and_no_fourth_star_give_three_star_hypotheses(random_db):
    frame = next(frames(random_db.catalog, random_db.camera, 3, seed=4))
    for ours, literal in (("triangle", "triangle_nopivot"), ("hybrid", "hybrid_nofourth")):
        first = _first_hypotheses(prepared_matcher(ours, random_db), frame.obs, 1)[0]
        lit = _first_hypotheses(prepared_matcher(literal, random_db), frame.obs, 1)[0]
        assert len(first.obs_index) == 4 and len(lit.obs_index) == 3


def test_hybrid_fourth_star_checks_count_as_pivots(random_db):
    frame = next(frames(random_db.catalog, random_db.camera, 3, seed=4))
    counts = {}
    for name in ("hybrid", "hybrid_nofourth"):
        diag = MatchDiagnostics()
        next(iter(prepared_matcher(name, random_db).hypotheses(frame.obs, diag)))
        counts[name] = diag.pivots
    assert counts["hybrid"] >= 1 and counts["hybrid_nofourth"] == 0


def test_field_rings_are_the_largest_and_smallest_separation():
    v = np.array([[0, 0, 1], [0.01, 0, 1], [0, 0.03, 1.0]])
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    d = angle_table(v, v)
    radius, width = field_rings(v)
    assert radius == pytest.approx(d.max()) and width == pytest.approx(d[0, 1])


def test_side_side_side_over_the_pair_table_finds_the_true_triangle(random_db):
    frame = next(frames(random_db.catalog, random_db.camera, 3, seed=8))
    ov = frame.obs.vectors[:3]
    tri = pair_triangles(random_db.pairs, angle_table(ov, ov), 0, 1, 2, 1e-5)
    assert any(np.array_equal(t, frame.truth_rows[:3]) for t in tri)
    cat = random_db.vectors
    for t in tri:  # every returned triangle has all three sides within the window
        assert pairs_off(ov, cat[t], 1e-5) == 0


def test_known_patch_restricts_the_catalog(random_db):
    matcher = prepared_matcher("radial_patch", random_db, patch_deg=15.0)  # > the field
    frame = next(frames(random_db.catalog, random_db.camera, 3, seed=6))
    boresight = frame.rotation.apply([0.0, 0.0, 1.0])
    matcher.patch_center = boresight
    assert_correct(identify(frame.obs, matcher), frame.truth_rows)
    matcher.patch_center = -boresight  # the wrong side of the sky: nothing to find
    assert not identify(frame.obs, matcher).solved


def test_bad_variant_keywords_are_refused(random_db):
    from startrack.matchers import get_matcher

    with pytest.raises(ValueError, match="closing"):
        get_matcher("angle")(random_db, closing="sometimes")
    with pytest.raises(ValueError, match="rings"):
        get_matcher("radial")(random_db, rings="coarse")
