"""Pyramid's compiled lost-in-space search (startrack._core.matchers.pyramid) held to the numba
search it replaced (tests/matchers/pyramid_reference.py, its steps in plain Python): the same
hypotheses in the same order, and the same counters, on real-sky frames with false stars
and on random centroids (no star pattern); and the pair tables' neighbour lists
(startrack._core.database.pair_tables) to their definition. The angle search is held to its
reference
in tests/matchers/test_angle_search.py, the joins in tests/matchers/test_matching.py."""

from __future__ import annotations

import numpy as np
import pyramid_reference
from synth import frames, prepared_matcher

from startrack._core.database import pair_tables as core_pairs
from startrack._core.matchers import pyramid as core_pyramid
from startrack.match_records import Observation
from startrack.matchers._pyramid import CONFIRM_RADIUS
from startrack.matchers._shared.pair_joins import pair_index
from startrack.matchers._shared.triples import triple_array


def _junk(camera, n_sets: int, seed: int) -> list[Observation]:
    rng = np.random.default_rng(seed)
    return [Observation.from_pixels(rng.uniform(0, camera.width - 1, n),
                                    rng.uniform(0, camera.height - 1, n), camera, 1.0)
            for n in rng.integers(4, 30, n_sets)]


def _reference_search(m, obs) -> tuple[list, list]:
    """Every (next triple, stars, rows) the reference search gives on ``obs``, and its
    counters."""
    n = min(m.config.max_stars + max(m.extra_stars, 0), len(obs))
    first = min(m.config.max_stars, n)
    vec = np.ascontiguousarray(obs.vectors[:n])
    tol = m.angle_tolerance(obs)
    n_cat = len(m.database.vectors)
    tab = pair_index(m._tables()[0], n_cat)
    tab = (tab.pi, tab.pj, tab.angle, *tab.lists)
    full = pair_index(m.database.pairs, n_cat).lists
    ang, stats = np.full((n, n), np.nan), np.zeros(4, np.int64)
    heads = np.full((2, n_cat), -1, np.int64)
    triples, start, answers = triple_array(first, n, m.max_triples), 0, []
    while start < len(triples):
        start, cols, rows = pyramid_reference.search(
            triples, start, ang, vec, tol, CONFIRM_RADIUS * tol, m.database.vectors,
            m.max_triangles, m.max_pyramids, tab, full, stats, heads)
        answers.append((start, cols, rows))
    return answers, stats.tolist()


def _searcher(m) -> core_pyramid.PyramidSearch:
    return core_pyramid.PyramidSearch(
        m.database.vectors, pair_index(m.database.pairs, len(m.database.vectors)).neighbours,
        m.max_triangles, m.max_pyramids)


def _compiled_search(m, obs, search=None) -> tuple[list, list]:
    n = min(m.config.max_stars + max(m.extra_stars, 0), len(obs))
    first = min(m.config.max_stars, n)
    tol = m.angle_tolerance(obs)
    n_cat = len(m.database.vectors)
    search = search or _searcher(m)
    frame = core_pyramid.PyramidFrame(obs.vectors[:n], tol, CONFIRM_RADIUS * tol)
    tab = pair_index(m._tables()[0], n_cat).neighbours
    triples, start, answers = triple_array(first, n, m.max_triples), 0, []
    while start < len(triples):
        start, cols, rows = core_pyramid.search(search, frame, tab, triples, start)
        answers.append((start, cols, rows))
    return answers, [frame.triples, frame.triangles, frame.candidates, frame.pivots]


def test_pyramid_search_gives_the_reference_answers(hip_db):
    matcher = prepared_matcher("pyramid", hip_db, max_triples=40)  # the reference is slow
    sky = list(frames(hip_db.catalog, hip_db.camera, 4, seed=5, noise_px=1.0,
                      false_stars=4, missing=0.2))
    assert sky
    checked = three_star_answers = 0
    three = [Observation.from_pixels(f.obs.x[r], f.obs.y[r], hip_db.camera, 1.0)
             for f in sky for r in [np.flatnonzero(f.truth_rows >= 0)[:3]]]  # no 4th star
    for obs in [f.obs for f in sky] + _junk(hip_db.camera, 2, seed=9) + three:
        got, got_stats = _compiled_search(matcher, obs)
        want, want_stats = _reference_search(matcher, obs)
        assert got_stats == want_stats
        assert len(got) == len(want)
        for (s_a, c_a, r_a), (s_b, c_b, r_b) in zip(got, want, strict=True):
            assert s_a == s_b
            assert np.array_equal(c_a, c_b) and np.array_equal(r_a, r_b)
            checked += len(r_a)
            three_star_answers += len(c_a) == 3 and len(r_a) > 0
    assert checked > 0 and three_star_answers > 0


def test_one_search_serves_every_frame_and_its_answers_stay_as_given(hip_db):
    """A matcher keeps one PyramidSearch (its scratch reused by every frame and triple):
    each frame's answers are those of a fresh search, and an answer already handed out
    is not overwritten by a later search."""
    matcher = prepared_matcher("pyramid", hip_db, max_triples=40)
    sky = [f.obs for f in frames(hip_db.catalog, hip_db.camera, 6, seed=7, noise_px=0.5,
                                 false_stars=3, missing=0.1)]
    shared, kept = _searcher(matcher), []
    for obs in sky + _junk(hip_db.camera, 3, seed=4) + sky[:2]:
        got, _ = _compiled_search(matcher, obs, shared)
        want, _ = _compiled_search(matcher, obs)
        assert [(s, c.tolist(), r.tolist()) for s, c, r in got] == \
            [(s, c.tolist(), r.tolist()) for s, c, r in want]
        kept.append((got, [(s, c.copy(), r.copy()) for s, c, r in got]))
    for handed, copied in kept:  # what every search returned, after all the others
        for (_, c_a, r_a), (_, c_b, r_b) in zip(handed, copied, strict=True):
            assert np.array_equal(c_a, c_b) and np.array_equal(r_a, r_b)
    assert sum(len(r) for got, _ in kept for _, _, r in got) > 0


def test_neighbour_lists_list_each_stars_partners_by_angle():
    rng = np.random.default_rng(1)
    i, j = rng.integers(0, 40, 400), rng.integers(0, 40, 400)
    i, j = i[i < j], j[i < j]
    angle = np.sort(rng.uniform(0, 0.2, len(i)))
    tab = core_pairs.PairNeighbours(i, j, angle, 40)
    start_lo, nbr_lo, ang_lo, start_hi, nbr_hi, ang_hi = tab.lists
    for s in range(40):
        assert np.array_equal(nbr_lo[start_lo[s]:start_lo[s + 1]], j[i == s])
        assert np.array_equal(ang_lo[start_lo[s]:start_lo[s + 1]], angle[i == s])
        assert np.array_equal(nbr_hi[start_hi[s]:start_hi[s + 1]], i[j == s])
        assert np.array_equal(ang_hi[start_hi[s]:start_hi[s + 1]], angle[j == s])

