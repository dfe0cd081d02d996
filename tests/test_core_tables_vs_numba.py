"""The compiled database builds and triangle/hybrid searches (startrack._core.database,
triangles, hybrid) against the numba kernels they replace, bit for bit: seeded random
inputs and the session's random-sky database tables."""

from __future__ import annotations

import math

import numpy as np
import pytest
from synth import frames, prepared_matcher

from startrack._core import database as cdb
from startrack._core import hybrid as chy
from startrack._core import triangles as ctri
from startrack.database import build_kernels, sort_kernels
from startrack.matchers import MatcherConfig
from startrack.matching import hybrid_kernels, hybrid_search
from startrack.matching import triangle_lookup as tl
from startrack.matching.feature_kernels import features as numba_features
from startrack.matching.geometry import angle_table, handedness
from startrack.matching.pairs import pair_index
from startrack.matching.triangle_search import join_pivot as numba_join_pivot
from startrack.matching.triangle_search import next_answer as numba_next_answer
from startrack.matching.triples import brightness_triples


def _equal(got, want) -> None:
    for g, w in zip(got, want, strict=True):
        g, w = np.asarray(g), np.asarray(w)
        assert g.dtype == w.dtype and g.shape == w.shape and g.tobytes() == w.tobytes()


def test_builds_on_the_random_sky_tables(random_db):
    v = np.ascontiguousarray(random_db.vectors)
    _equal(cdb.close_pairs(v, random_db.max_angle_rad),
           build_kernels.close_pairs(v, random_db.max_angle_rad))
    i, j, ang = build_kernels.close_pairs(v, random_db.max_angle_rad)
    order = sort_kernels.stable_argsort(ang, 0.0, random_db.max_angle_rad)
    np.testing.assert_array_equal(cdb.stable_argsort(ang, 0.0, random_db.max_angle_rad), order)
    _equal(cdb.take_pairs(order, i, j, ang), sort_kernels.take_pairs(order, i, j, ang))
    p = random_db.pairs
    lo, hi = np.minimum(p.i, p.j).astype(np.int64), np.maximum(p.i, p.j).astype(np.int64)
    tri = build_kernels.triangles_of_pairs(len(v), lo[:20000], hi[:20000], v)
    _equal(cdb.triangles_of_pairs(len(v), lo[:20000], hi[:20000], v), tri)
    order = sort_kernels.stable_argsort(tri[1], 0.0, float(tri[1].max()))
    np.testing.assert_array_equal(cdb.stable_argsort(tri[1], 0.0, float(tri[1].max())), order)
    _equal(cdb.take_triangles(order, *tri), sort_kernels.take_triangles(order, *tri))
    kv = random_db.triangles.kvector
    _equal([cdb.count_at_most(kv.values, kv.m, kv.q)],
           [sort_kernels.count_at_most(kv.values, kv.m, kv.q)])
    assert cdb.is_sorted(kv.values) and not cdb.is_sorted(tri[1][::-1].copy())


def test_sorts_on_seeded_values():
    rng = np.random.default_rng(21)
    for values in (rng.uniform(0, 1, 4000), rng.normal(0.5, 1e-6, 3000).clip(0, 1),
                   np.repeat(rng.uniform(0, 1, 50), 40), np.array([0.25])):
        np.testing.assert_array_equal(cdb.stable_argsort(values, 0.0, 1.0),
                                      sort_kernels.stable_argsort(values, 0.0, 1.0))
        s = np.sort(values)
        np.testing.assert_array_equal(cdb.count_at_most(s, 1e-4, -1e-9),
                                      sort_kernels.count_at_most(s, 1e-4, -1e-9))


def test_features_mapping_and_joins_on_seeded_inputs():
    rng = np.random.default_rng(17)
    v = rng.normal([0, 0, 1], 0.1, size=(40, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    for a, b, c in rng.integers(0, 40, (200, 3)):
        assert ctri.features(v[a], v[b], v[c], 2e-5) == numba_features(v[a], v[b], v[c], 2e-5)
    rows = rng.integers(0, 40, (300, 3))
    for t in range(20):
        obs = v[rows[t]] + rng.normal(0, 3e-4, (3, 3))
        for tol, mirror in [(2e-3, True), (1e-2, False)]:
            _equal(ctri.map_vertices(obs, rows, v, tol, mirror),
                   tl.map_vertices(obs, rows, v, tol, mirror))
    for width in (3, 5):
        left, right = rng.integers(0, 7, (50, width)), rng.integers(0, 7, (70, 3))
        _equal([ctri.join_pivot(left, 1, 2, right)], [numba_join_pivot(left, 1, 2, right)])


@pytest.mark.parametrize("sigmas", [4.0, 40.0])
def test_triangle_search_answers_and_counters(random_db, sigmas):
    _triangle_search(random_db, sigmas)


@pytest.mark.slow
def test_searches_on_the_hipparcos_tables(hip_db):
    _triangle_search(hip_db, 4.0)
    _hybrid_search(hip_db)


def _triangle_search(random_db, sigmas: float) -> None:
    matcher = prepared_matcher("triangle", random_db, MatcherConfig(tolerance_sigma=sigmas))
    table = matcher.database.triangles
    kv = table.kvector
    numba_table = (kv.values, kv.k, kv.m, kv.q, table.polar, np.ascontiguousarray(table.rows),
                   np.ascontiguousarray(random_db.vectors))
    catalog = ctri.TriangleCatalog(table, random_db.vectors)
    answers = 0
    for f in frames(random_db.catalog, random_db.camera, 4, seed=3, noise_px=1.0,
                    false_stars=2):
        vec, sigma = f.obs.vectors[:8], f.obs.sigma_rad
        triples = np.array(brightness_triples(len(vec)), np.int64)
        side_tol = sigmas * math.sqrt(2.0) * sigma
        frame = tl.frame_tuple(vec, triples, sigmas, side_tol, sigma)
        memo, state = tl.frame_memo(len(vec)), np.zeros(6, np.int64)
        search = ctri.TriangleSearch(catalog, vec, triples, sigmas, side_tol, sigma)
        t = 0
        while t <= len(triples):
            want_t, want_stars, want_rows, memo = numba_next_answer(
                t, triples, frame, numba_table, memo, state, 4, 5)
            got = search.next_answer(t, 4, 5)
            _equal(got, (want_t, want_stars, want_rows))
            assert (search.candidates, search.polar_kept, search.pivots, search.lookups) == (
                state[tl.CANDIDATES], state[tl.POLAR_KEPT], state[tl.PIVOTS], state[tl.LOOKUPS])
            answers += len(want_rows)
            t = want_t + 1
    assert answers > 0 and search.pivots > 0


def test_hybrid_search_steps(random_db):
    _hybrid_search(random_db)


def _hybrid_search(random_db) -> None:
    index = pair_index(random_db.pairs, len(random_db.vectors))
    heads = np.full(len(random_db.vectors), -1, np.int64)
    for f in frames(random_db.catalog, random_db.camera, 3, seed=8, noise_px=0.5,
                    false_stars=1):
        vec = np.ascontiguousarray(f.obs.vectors[:7])
        n, tol = len(vec), 4.0 * math.sqrt(2.0) * f.obs.sigma_rad
        ang = angle_table(vec)
        windows = np.stack([np.searchsorted(index.angle, ang - tol, "left"),
                            np.searchsorted(index.angle, ang + tol, "right")], axis=-1)
        windows = np.ascontiguousarray(np.maximum(windows, windows[..., :1]))
        votes = chy.angle_votes(index.pi, index.pj, windows, index.n_catalog)
        _equal([votes], [hybrid_kernels.angle_votes(index.pi, index.pj, windows,
                                                    index.n_catalog)])
        tri = np.array(brightness_triples(n), np.int64)
        feats = chy.triple_features(vec, tri, f.obs.sigma_rad)
        _equal([feats], [hybrid_kernels.triple_features(vec, tri, f.obs.sigma_rad)])
        hands = np.where(feats[:, 0] > 4.0 * feats[:, 2], handedness(
            vec[tri[:, 0]], vec[tri[:, 1]], vec[tri[:, 2]]), 0).astype(np.int64)
        for short in (votes >= n - 1, votes >= n - 3):
            lists = hybrid_kernels.shortlisted_pairs(index.pi, index.pj, windows, short)
            pairs = chy.ShortPairs(index.pi, index.pj, windows, short)
            _equal((pairs.start, pairs.xs, pairs.ys), lists)
            frame = chy.HybridFrame(tri, feats, hands, ang, tol, 4.0)
            search = chy.HybridSearch(frame, pairs, short, random_db.vectors,
                                      chy.PairNeighbours(*index.lists), heads, 5, 10)
            _same_confirmed(search, (tri, feats, hands, lists, random_db.vectors, 4.0, heads,
                                     ang, tol, short, index.lists, 5))
            stats, t = np.zeros(1, np.int64), 0
            while t < len(tri):
                want = hybrid_search.next_triangles(t, tri, feats, hands, lists,
                                                    random_db.vectors, 4.0, heads, stats)
                _equal(search.next_triangles(t), want)
                t = want[0] + 1


CONFIRMED: list[int] = []


def _same_confirmed(search, args) -> None:
    best_rows, best_err = np.empty((10, 6), np.int64), np.empty(10)
    stats, t = np.zeros(3, np.int64), 0
    while t < len(args[0]):
        want = hybrid_search.next_confirmed(t, *args, best_rows, best_err, stats)
        _equal(search.next_confirmed(t), want)
        CONFIRMED.append(len(want[2]))
        assert (search.tested, search.fourth_tried, search.best_kept) == tuple(stats)
        t = want[0] + 1
    _equal((search.best_rows[:stats[2]], search.best_err[:stats[2]]),
           (best_rows[:stats[2]], best_err[:stats[2]]))
