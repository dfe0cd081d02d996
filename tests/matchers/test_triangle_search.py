"""The compiled triangle search (startrack._core.matchers.triangles)
against the numpy and Python search it replaced (tests/matchers/triangle_reference.py): the same
hypotheses in the same order and the same diagnostics at every step, on frames with false
and missing stars and on random centroids (no star pattern); and its parts (features,
k-vector range, vertex mapping, pivot join) against their numpy counterparts."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from synth import frames, prepared_matcher
from triangle_reference import map_vertices as reference_map_vertices
from triangle_reference import reference_hypotheses

from startrack._core import shared
from startrack._core.matchers import triangles as tl
from startrack.database import KVector, binary_search_range
from startrack.match_records import MatchDiagnostics, Observation
from startrack.matchers import MatcherConfig
from startrack.matchers._shared.features import observed_features
from startrack.matchers._shared.pair_joins import join_sorted


def _junk(camera, n_sets: int, seed: int) -> list[Observation]:
    rng = np.random.default_rng(seed)
    return [Observation.from_pixels(rng.uniform(0, camera.width - 1, n),
                                    rng.uniform(0, camera.height - 1, n), camera, 1.0)
            for n in rng.integers(3, 40, n_sets)]


def _steps(hypotheses, diag: MatchDiagnostics) -> list[tuple]:
    """Each hypothesis with the diagnostics as they stood when it came: a consumer that
    stops there (verification's acceptance) sees these counts."""
    return [(h.obs_index.tolist(), h.cat_index.tolist(), diag.candidates, diag.pivots,
             dict(diag.extra)) for h in hypotheses]


def _same(matcher, obs: Observation) -> int:
    d_new, d_ref = MatchDiagnostics(), MatchDiagnostics()
    new = _steps(matcher.hypotheses(obs, d_new), d_new)
    ref = _steps(reference_hypotheses(matcher, obs, d_ref), d_ref)
    assert new == ref
    assert (d_new.candidates, d_new.pivots, d_new.extra) == (
        d_ref.candidates, d_ref.pivots, d_ref.extra)
    return len(new)


@pytest.mark.parametrize("method", ["triangle", "triangle_nopivot"])
def test_same_hypotheses_as_the_python_search(random_db, method):
    matcher = prepared_matcher(method, random_db)
    sky = list(frames(random_db.catalog, random_db.camera, 6, seed=5, noise_px=1.0,
                      false_stars=3, missing=0.2))
    assert sky
    counts = [_same(matcher, obs) for obs in [f.obs for f in sky]
              + _junk(random_db.camera, 6, seed=9)]
    assert sum(counts) > 0


def test_wide_windows_force_pivots_and_give_the_same_hypotheses(random_db):
    """40-sigma windows: hundreds of catalog triangles per lookup, long pivot chains."""
    matcher = prepared_matcher("triangle", random_db, MatcherConfig(tolerance_sigma=40.0))
    for obs in [f.obs for f in frames(random_db.catalog, random_db.camera, 3, seed=71,
                                      noise_px=0.3, false_stars=1)]:
        assert _same(matcher, obs) > 0


def test_interleaved_searches_keep_their_own_memo(random_db):
    """Two searches alive at once (one abandoned midway) do not share buffers."""
    matcher = prepared_matcher("triangle", random_db, MatcherConfig(tolerance_sigma=40.0))
    a, b = _junk(random_db.camera, 2, seed=3)
    want_a = _steps(reference_hypotheses(matcher, a, d := MatchDiagnostics()), d)
    want_b = _steps(reference_hypotheses(matcher, b, e := MatchDiagnostics()), e)
    d_a, d_b = MatchDiagnostics(), MatchDiagnostics()
    gen_a, gen_b = matcher.hypotheses(a, d_a), matcher.hypotheses(b, d_b)
    got_a, got_b = [], []
    for ha, hb in itertools.zip_longest(gen_a, gen_b):
        for h, got, dd in ((ha, got_a, d_a), (hb, got_b, d_b)):
            if h is not None:
                got.extend(_steps([h], dd))
    assert (got_a, got_b) == (want_a, want_b)
    partial = matcher.hypotheses(a, MatchDiagnostics())
    next(partial, None)
    partial.close()  # its buffers go back to the pool
    assert _same(matcher, b) == len(want_b)


def test_kvector_range_is_the_binary_search():
    """The compiled k-vector range the triangle lookup uses answers as a binary search
    does, empty and NaN ranges included."""
    rng = np.random.default_rng(1)
    values = np.sort(rng.exponential(1.0, 5000))
    kv = KVector.build(values)
    for lo, hi in [(0.1, 0.2), (-1.0, 0.0), (3.0, 2.0), (0.5, 0.5), (10.0, 99.0),
                   (values[7], values[7]), *rng.uniform(0, 3, (40, 2)).tolist()]:
        want = binary_search_range(values, lo, hi) if lo <= hi else (0, 0)
        assert shared.kvector_range(kv.values, kv.k, kv.m, kv.q, lo, hi) == want
    assert shared.kvector_range(kv.values, kv.k, kv.m, kv.q, np.nan, 1.0) == (0, 0)


def test_triple_features_are_the_batch_features_to_the_bit():
    """Computed triple by triple, only when looked up, the windows must be the batch's."""
    rng = np.random.default_rng(3)
    triples = list(itertools.combinations(range(8), 3))
    for spread in (0.01, 0.1, None):
        v = rng.normal(size=(8, 3)) if spread is None else rng.normal([0, 0, 1], spread,
                                                                      size=(8, 3))
        v /= np.linalg.norm(v, axis=1, keepdims=True)
        sigma = float(rng.uniform(1e-6, 1e-4))
        want = observed_features(v, triples, sigma)
        for a, b, c in triples:
            assert tl.features(v[a], v[b], v[c], sigma) == want[a, b, c]


def _sky_triangles(rng, m: int) -> tuple[np.ndarray, np.ndarray]:
    vectors = rng.normal([0, 0, 1], 0.08, size=(60, 3))
    vectors /= np.linalg.norm(vectors, axis=1, keepdims=True)
    rows = np.array([rng.choice(60, 3, replace=False) for _ in range(m)])
    return vectors, rows


def test_map_vertices_is_the_numpy_mapping_to_the_bit():
    """Same candidates, orders and tie order: the sides and handedness are the numpy
    reference's numbers, not approximations of them."""
    rng = np.random.default_rng(6)
    vectors, rows = _sky_triangles(rng, 400)
    rows[200:] = rows[:200, [1, 0, 2]]  # the same triangles again, other vertex orders
    for t in range(25):
        obs = vectors[rows[t]] + rng.normal(0, 2e-4, (3, 3))
        obs = obs[rng.permutation(3)]
        for tol, mirror in [(1e-3, True), (5e-3, False), (0.02, True)]:
            got = tl.map_vertices(obs, rows, vectors, tol, mirror)
            want = reference_map_vertices(obs, vectors[rows], tol, mirror)
            for g, w in zip(got, want, strict=True):
                np.testing.assert_array_equal(g, w)


def test_map_vertices_finds_the_order_and_refuses_the_mirror():
    rng = np.random.default_rng(2)
    vectors = rng.normal([0, 0, 1], 0.1, size=(3, 3))
    vectors /= np.linalg.norm(vectors, axis=1, keepdims=True)
    rows = np.array([[2, 0, 1]])
    cand, perm = tl.map_vertices(vectors, rows, vectors, 1e-9, True)
    assert cand.tolist() == [0]
    assert rows[0, tl.PERMS[perm[0]]].tolist() == [0, 1, 2]  # observed v is catalog v
    mirror = vectors * np.array([1, -1, 1])  # a reflection keeps every side
    assert len(tl.map_vertices(mirror, rows, vectors, 1e-9, True)[0]) == 0
    assert len(tl.map_vertices(mirror, rows, vectors, 1e-9, False)[0]) >= 1


def test_join_pivot_is_join_sorted():
    rng = np.random.default_rng(8)
    for width in (3, 4, 6):
        left = rng.integers(0, 9, size=(60, width))
        right = rng.integers(0, 9, size=(80, 3))
        for cols in [(1, 2), (width - 2, width - 1), (2, 0)]:
            np.testing.assert_array_equal(tl.join_pivot(left, *cols, right),
                                          join_sorted(left, cols, right))
    assert tl.join_pivot(left, 0, 1, right[:0]).shape == (0, width + 1)


@pytest.mark.slow
def test_same_hypotheses_on_the_real_sky(hip_db):
    """Hipparcos with its pattern-star cap; building the triangle table takes seconds."""
    matcher = prepared_matcher("triangle", hip_db)
    sky = list(frames(hip_db.catalog, hip_db.camera, 6, seed=5, noise_px=1.0,
                      false_stars=4, missing=0.2))
    for obs in [f.obs for f in sky] + _junk(hip_db.camera, 8, seed=9):
        _same(matcher, obs)
