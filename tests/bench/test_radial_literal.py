"""The radial-features paper's literal variants (equations 3 and 4, the known patch) and its
own measure, every star identified (startrack.bench._star_labels)."""

from __future__ import annotations

import numpy as np
import pytest
from synth import assert_correct, frames, prepared_matcher, with_false_star

from startrack.bench._star_labels import (
    StarLabels,
    label_every_star,
    score_labels,
    star_triangles,
)
from startrack.matchers import angle_table
from startrack.matchers._shared.radial_rings import paper_rings, separation_range
from startrack.solver import identify


def _frame(db, seed=6, **kw):
    return next(frames(db.catalog, db.camera, 5, seed=seed, min_stars=10, **kw))


def _pointed(method, db, frame, **params):
    matcher = prepared_matcher(method, db, **params)
    matcher.patch_center = frame.rotation.apply([0.0, 0.0, 1.0])
    return matcher


def test_paper_rings_take_both_star_sets():
    v = np.array([[0, 0, 1], [0.01, 0, 1], [0, 0.03, 1.0]])
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    obs_max, obs_min = separation_range(v)
    assert paper_rings(v, (obs_max * 2, obs_min * 3)) == (obs_max * 2, obs_min)
    assert paper_rings(v, (obs_max / 2, obs_min / 4)) == (obs_max, obs_min / 4)


def test_the_literal_threshold_counts_every_ring(random_db):
    """l >= 3/4 Nq over every ring is never easier than over the rings a star occupies;
    a star with fewer neighbours than 3/4 Nq gets no candidate at all."""
    frame = _frame(random_db)
    common = dict(rings="paper", edge_tolerance=False, min_rings=1, cap=10_000)
    occupied = prepared_matcher("radial", random_db, threshold="occupied", **common)
    every = prepared_matcher("radial", random_db, threshold="all", **common)
    n = len(frame.obs)
    table = every.frame_table(frame.obs)
    neighbours = np.count_nonzero(
        angle_table(frame.obs.vectors, frame.obs.vectors) < table.radius_rad, axis=1) - 1
    for k, (a, b) in enumerate(zip(occupied.shortlists(frame.obs, n),
                                   every.shortlists(frame.obs, n), strict=True)):
        assert set(b) <= set(a)
        if neighbours[k] < 0.75 * table.n_rings:
            assert len(b) == 0


def test_literal_rings_in_a_patch_come_from_its_stars(random_db):
    frame = _frame(random_db)
    matcher = _pointed("radial_paper_patch", random_db, frame, patch_deg=15.0)
    radius, width = matcher.frame_rings(frame.obs)
    patch = random_db.vectors[matcher.in_patch()]
    assert radius >= separation_range(patch)[0] - 1e-12
    assert width <= min(separation_range(patch)[1], separation_range(frame.obs.vectors)[1])
    lost = prepared_matcher("radial_paper", random_db)
    assert lost.frame_rings(frame.obs)[1] <= width  # the whole sky's closest pair


def test_sss_patch_identifies_and_the_wrong_patch_finds_nothing(random_db):
    frame = _frame(random_db, seed=8)
    matcher = _pointed("sss_patch", random_db, frame, patch_deg=15.0)
    assert_correct(identify(frame.obs, matcher), frame.truth_rows)
    matcher.patch_center = -matcher.patch_center
    assert not identify(frame.obs, matcher).solved


def test_sss_patch_without_a_patch_is_lost_in_space(random_db):
    frame = _frame(random_db, seed=8)
    assert_correct(identify(frame.obs, prepared_matcher("sss_patch", random_db)),
                   frame.truth_rows)


def test_star_triangles_cover_every_star_once_each():
    rng = np.random.default_rng(2)
    v = rng.normal(size=(7, 3)) * 0.05 + [0, 0, 1]
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    tris = star_triangles(angle_table(v, v), 3)
    assert len(tris) == len(set(tris)) and all(a < b < c for a, b, c in tris)
    assert {s for t in tris for s in t} == set(range(7))


@pytest.mark.parametrize("method", ["radial", "sss"])
def test_every_star_of_an_exact_frame_is_labelled_right(random_db, method):
    frame = _frame(random_db, seed=4)
    labels = label_every_star(prepared_matcher(method, random_db), frame.obs)
    score = score_labels(labels, frame.truth_rows)
    assert score["misidentified"] == 0 and score["duplicates"] == 0
    assert score["right"] >= score["real"] - 2  # a star far from the rest may get no vote


def test_a_false_star_is_never_labelled_by_the_radial_prefilter(random_db):
    frame = _frame(random_db, seed=4, noise_px=0.3)
    obs, truth = with_false_star(frame, 0, np.random.default_rng(1))
    score = score_labels(label_every_star(prepared_matcher("radial", random_db), obs), truth)
    assert score["false_labelled"] == 0 and score["misidentified"] == 0


def test_score_labels_counts_wrong_false_and_twice_given_stars():
    labels = StarLabels(np.array([5, 5, 7, -1, 9]), np.ones(5, np.int64))
    score = score_labels(labels, np.array([5, 6, 7, 8, -1]))
    assert score == {"stars": 5, "real": 4, "identified": 4, "right": 2,
                     "misidentified": 2, "false_labelled": 1, "duplicates": 1}


def test_a_patch_shortlist_is_the_full_one_filtered(random_db):
    """Scoring only the patch's rows ranks them as scoring every row and then filtering."""
    from startrack.database import observed_masks

    frame = _frame(random_db)
    matcher = _pointed("radial_patch", random_db, frame, patch_deg=15.0)
    table, patch = matcher.table, matcher.in_patch()
    single, double, need = observed_masks(frame.obs.vectors, np.arange(5), table.radius_rad,
                                          table.ring_width_rad, 1e-4)
    for k in range(5):
        full, _ = table.shortlist(single[k], double[k], int(need[k]), cap=len(random_db.vectors))
        part, _ = table.shortlist(single[k], double[k], int(need[k]), cap=10, among=patch)
        np.testing.assert_array_equal(part, full[np.isin(full, patch)][:10])


def _unit(spec, condition, frame, *, scale):
    return [{"condition": condition, "frame": frame, "value": scale * (condition + frame)}]


def test_map_units_runs_every_condition_and_frame_in_canonical_order():
    from types import SimpleNamespace

    from startrack.bench._raw import map_units

    spec = SimpleNamespace(conditions=("a", "b"), frames=5)
    table = map_units(_unit, spec, 3, scale=10)
    assert list(zip(table["condition"], table["frame"], strict=True)) == [
        (0, 0), (0, 1), (0, 2), (1, 0), (1, 1), (1, 2)]
    assert table["value"].tolist() == [0, 10, 20, 10, 20, 30]
    assert len(map_units(_unit, spec, 9, scale=1)) == 10  # capped at the run's frames


def test_equation_5_alone_yields_every_matching_triangle(random_db):
    """`sss_paper`: every catalog triangle within eps of the observed sides, three stars
    each, no cap; ours caps at ``max_matches`` and orders by a fourth star."""
    from startrack.match_records import MatchDiagnostics

    frame = _frame(random_db, seed=8, noise_px=2.0, sigma_px=20.0)  # wide windows
    literal = list(prepared_matcher("sss_paper", random_db).hypotheses(
        frame.obs, MatchDiagnostics()))
    ours = list(prepared_matcher("sss", random_db).hypotheses(frame.obs, MatchDiagnostics()))
    assert all(len(h.obs_index) == 3 for h in literal)
    per_triangle = np.unique([tuple(h.obs_index) for h in literal], axis=0,
                             return_counts=True)[1]
    assert per_triangle.max() > 8, "the wide windows hold more than our cap"
    assert len(literal) > len(ours)
    assert any(len(h.obs_index) == 4 for h in ours)


def test_equation_5_alone_in_the_patch_identifies_an_exact_frame(random_db):
    frame = _frame(random_db, seed=8)
    matcher = _pointed("sss_paper_patch", random_db, frame, patch_deg=15.0)
    assert_correct(identify(frame.obs, matcher), frame.truth_rows)
