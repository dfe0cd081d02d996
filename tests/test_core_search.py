"""The compiled lost-in-space searches (startrack._core.pyramid, startrack._core.angle)
held to the searches they replaced: the same hypotheses in the same order, and the same
counters, on real-sky frames with false stars and on random centroids (no star
pattern); and the pair-table joins (startrack._core.pairs) to their definitions."""

from __future__ import annotations

import numpy as np
import pyramid_reference
import pytest
from synth import frames, prepared_matcher

from startrack._core import angle as core_angle
from startrack._core import pairs as core_pairs
from startrack._core import pyramid as core_pyramid
from startrack.matchers.pyramid import CONFIRM_RADIUS
from startrack.matching.pairs import pair_index
from startrack.matching.triples import triple_array
from startrack.types import Observation


def _junk(camera, n_sets: int, seed: int) -> list[Observation]:
    rng = np.random.default_rng(seed)
    return [Observation.from_pixels(rng.uniform(0, camera.width - 1, n),
                                    rng.uniform(0, camera.height - 1, n), camera, 1.0)
            for n in rng.integers(4, 30, n_sets)]


def _reference_search(m, obs, reference) -> tuple[list, list]:
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
        start, cols, rows = reference.search(
            triples, start, ang, vec, tol, CONFIRM_RADIUS * tol, m.database.vectors,
            m.max_triangles, m.max_pyramids, tab, full, stats, heads)
        answers.append((start, cols, rows))
    return answers, stats.tolist()


def _compiled_search(m, obs) -> tuple[list, list]:
    n = min(m.config.max_stars + max(m.extra_stars, 0), len(obs))
    first = min(m.config.max_stars, n)
    tol = m.angle_tolerance(obs)
    n_cat = len(m.database.vectors)
    search = core_pyramid.PyramidSearch(m.database.vectors,
                                        pair_index(m.database.pairs, n_cat).neighbours,
                                        m.max_triangles, m.max_pyramids)
    frame = core_pyramid.PyramidFrame(obs.vectors[:n], tol, CONFIRM_RADIUS * tol)
    tab = pair_index(m._tables()[0], n_cat).neighbours
    triples, start, answers = triple_array(first, n, m.max_triples), 0, []
    while start < len(triples):
        start, cols, rows = core_pyramid.search(search, frame, tab, triples, start)
        answers.append((start, cols, rows))
    return answers, [frame.triples, frame.triangles, frame.candidates, frame.pivots]


def _references():
    refs = [pyramid_reference]
    try:  # the numba kernels, while they exist
        from startrack.matching import pyramid_kernels
    except ImportError:
        return refs
    return [pyramid_kernels, *refs]


@pytest.mark.parametrize("reference", _references(), ids=lambda r: r.__name__)
def test_pyramid_search_gives_the_reference_answers(hip_db, reference):
    matcher = prepared_matcher("pyramid", hip_db)
    sky = list(frames(hip_db.catalog, hip_db.camera, 4, seed=5, noise_px=1.0,
                      false_stars=4, missing=0.2))
    assert sky
    checked = 0
    for obs in [f.obs for f in sky] + _junk(hip_db.camera, 2, seed=9):
        got, got_stats = _compiled_search(matcher, obs)
        want, want_stats = _reference_search(matcher, obs, reference)
        assert got_stats == want_stats
        assert len(got) == len(want)
        for (s_a, c_a, r_a), (s_b, c_b, r_b) in zip(got, want, strict=True):
            assert s_a == s_b
            assert np.array_equal(c_a, c_b) and np.array_equal(r_a, r_b)
            checked += len(r_a)
    assert checked > 0


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


def _angle_inputs(m, obs, screen_rad):
    n = min(m.config.max_stars + max(m.extra_stars, 0), len(obs))
    first = min(m.config.max_stars, n)
    index = pair_index(m._table(), len(m.database.vectors))
    pi, pj, slot_rows = m._slots
    windows = m._windows(index, obs.vectors[:n], m.angle_tolerance(obs))
    cos_radius = -2.0 if screen_rad is None else np.cos(screen_rad)
    return first, triple_array(first, n, m.max_chains), windows, pi, pj, cos_radius


def _numba_chains(m, obs, screen_rad, angle_search) -> tuple[list, list]:
    first, triples, windows, pi, pj, cos_radius = _angle_inputs(m, obs, screen_rad)
    n = len(windows)
    groups, memo = angle_search.frame_arrays(windows, len(m._slots[2]))
    seen, state = np.zeros((n, n), np.bool_), np.zeros(8, np.int64)
    state[0] = m.max_lookups
    params = np.array([m.max_skips, m.max_ambiguous, m.max_rows,
                       ("until_one", "all", "none").index(m.closing)], np.int64)
    screen = (np.ascontiguousarray(obs.vectors[:n]), m._slot_vectors, cos_radius)
    t, answers = 0, []
    while t < len(triples):
        t, cols, rows = angle_search.next_chain(t, triples, first, windows, seen, state,
                                                pi, pj, groups, memo, params, screen)
        answers.append((t, cols, rows))
        t += 1
    return answers, state[1:].tolist()


def _compiled_chains(m, obs, screen_rad) -> tuple[list, list]:
    first, triples, windows, pi, pj, cos_radius = _angle_inputs(m, obs, screen_rad)
    limits = core_angle.AngleLimits(m.max_skips, m.max_ambiguous, m.max_rows,
                                    ("until_one", "all", "none").index(m.closing),
                                    m.max_lookups)
    frame = core_angle.AngleFrame(limits, windows, pi, pj, obs.vectors[:len(windows)],
                                  m._slot_vectors, cos_radius)
    t, answers = 0, []
    while t < len(triples):
        t, cols, rows = core_angle.next_chain(frame, triples, t, first)
        answers.append((t, cols, rows))
        t += 1
    first_event = 0 if not (frame.skipped or frame.ambiguous) else (
        6 if frame.ambiguous_first else 5)
    return answers, [frame.chains, frame.pivots, frame.candidates, frame.lookups,
                     frame.skipped, frame.ambiguous, first_event]


@pytest.mark.parametrize("method", ["angle", "angle_closed", "angle_open"])
def test_angle_chains_give_the_numba_answers(hip_db, method):
    angle_search = pytest.importorskip("startrack.matching.angle_search")
    matcher = prepared_matcher(method, hip_db)
    tight = prepared_matcher(method, hip_db, max_lookups=37, max_ambiguous=1)
    sky = list(frames(hip_db.catalog, hip_db.camera, 4, seed=5, noise_px=1.0,
                      false_stars=4, missing=0.2))
    for obs in [f.obs for f in sky] + _junk(hip_db.camera, 4, seed=9):
        for m in (matcher, tight):
            for screen in (None, 3.0 / hip_db.camera.f_px):
                got, got_state = _compiled_chains(m, obs, screen)
                want, want_state = _numba_chains(m, obs, screen, angle_search)
                assert got_state == want_state
                assert len(got) == len(want)
                for (t_a, c_a, r_a), (t_b, c_b, r_b) in zip(got, want, strict=True):
                    assert t_a == t_b
                    assert np.array_equal(c_a, c_b) and np.array_equal(r_a, r_b)
