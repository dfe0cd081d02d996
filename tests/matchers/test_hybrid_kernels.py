"""The hybrid matcher's compiled steps (startrack._core.matchers.hybrid) against brute force:
votes, shortlisted pairs, triangles among them (rows and their order), the observed
features, the best-so-far list and the confirmed search."""

from __future__ import annotations

import itertools

import numpy as np
from synth import frames

from startrack._core.matchers import hybrid as kernels
from startrack.database import build_pair_arrays, pair_table_from_arrays, triangle_features
from startrack.matchers._shared.features import observed_features
from startrack.matchers._shared.geometry import handedness
from startrack.matchers._shared.pair_joins import pair_index
from startrack.matchers._shared.triples import brightness_triples


def _sky(n: int = 60, seed: int = 5) -> np.ndarray:
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(n, 3)) * np.array([0.3, 0.3, 1.0]) + np.array([0.0, 0.0, 2.0])
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _setup(n_obs: int = 5, seed: int = 3):
    """A pair index of a small sky, each observed pair's window and random shortlists."""
    sky = _sky()
    index = pair_index(pair_table_from_arrays(build_pair_arrays(sky, 0.5)), len(sky))
    rng = np.random.default_rng(seed)
    m = len(index.pi)
    windows = np.zeros((n_obs, n_obs, 2), np.int64)
    for a, b in itertools.combinations(range(n_obs), 2):
        lo = int(rng.integers(0, m - 1))
        windows[a, b] = windows[b, a] = lo, min(m, lo + int(rng.integers(1, 300)))
    short = rng.random((n_obs, len(sky))) < 0.6
    return sky, index, windows, short


def _pairs_reference(index, windows, short, a, b):
    e0, e1 = windows[a, b]
    both = [(int(index.pi[e]), int(index.pj[e])) for e in range(e0, e1)]
    both += [(j, i) for i, j in both]
    return [(x, y) for x, y in both if short[a, x] and short[b, y]]


def test_angle_votes_count_each_window_once():
    sky, index, windows, _ = _setup()
    votes = kernels.angle_votes(index.pi, index.pj, windows, len(sky))
    want = np.zeros_like(votes)
    for a, b in itertools.combinations(range(len(windows)), 2):
        e0, e1 = windows[a, b]
        stars = np.unique(np.concatenate([index.pi[e0:e1], index.pj[e0:e1]]))
        want[a, stars] += 1
        want[b, stars] += 1
    assert np.array_equal(votes, want) and votes.max() >= 2


def test_shortlisted_pairs_are_the_window_both_ways_round_in_order():
    _, index, windows, short = _setup()
    lists = kernels.ShortPairs(index.pi, index.pj, windows, short)
    start, xs, ys, n = lists.start, lists.xs, lists.ys, len(short)
    for a, b in itertools.combinations(range(n), 2):
        got = list(zip(xs[start[a * n + b]:start[a * n + b + 1]].tolist(),
                       ys[start[a * n + b]:start[a * n + b + 1]].tolist(), strict=True))
        assert got == _pairs_reference(index, windows, short, a, b)
    assert len(xs) > 0


def test_shortlisted_triangles_match_brute_force():
    sky, index, windows, short = _setup()
    pairs = kernels.ShortPairs(index.pi, index.pj, windows, short)
    heads = np.full(len(sky), -1, np.int64)
    a, b, c = 0, 2, 3
    ab, bc = _pairs_reference(index, windows, short, a, b), _pairs_reference(
        index, windows, short, b, c)
    cand = [(x, y, z) for x, y in ab for y2, z in bc if y2 == y and z != x]
    assert len(cand) > 10
    trip = np.array(cand)
    area, polar = triangle_features(sky[trip[:, 0]], sky[trip[:, 1]], sky[trip[:, 2]])
    hand = handedness(sky[trip[:, 0]], sky[trip[:, 1]], sky[trip[:, 2]])
    # An observed triangle that some of the candidates match, within loose sigmas.
    feats = np.array([area[0], polar[0], 0.5 * area[0], 0.5 * polar[0]])
    for want_hand in (0, int(hand[0])):
        frame = kernels.HybridFrame([[a, b, c]], [feats], [want_hand],
                                    np.zeros((len(short), len(short))), 0.0, 2.0)
        search = kernels.HybridSearch(frame, pairs, short, sky,
                                      index.neighbours, heads, 5, 0)
        rows, err = search.triangles(0)
        tested = search.tested
        ok = (np.abs(area - feats[0]) <= 2 * feats[2]) & (np.abs(polar - feats[1])
                                                          <= 2 * feats[3])
        if want_hand:
            ok &= hand == want_hand
        assert tested == len(cand)
        assert np.array_equal(rows, trip[ok].reshape(-1, 3))
        assert np.allclose(err, np.hypot((area[ok] - feats[0]) / feats[2],
                                         (polar[ok] - feats[1]) / feats[3]))
        assert np.all(heads == -1)  # scratch left clean


def test_triple_features_match_observed_features():
    v = _sky(9, seed=8)
    triples = brightness_triples(9)
    want = np.array(list(observed_features(v, triples, 3e-4).values()))
    got = kernels.triple_features(v, np.array(triples), 3e-4)
    assert got.tobytes() == want.tobytes()  # the batch's numbers, to the bit


def test_keep_best_is_a_bounded_stable_sort():
    rng = np.random.default_rng(4)
    errs = rng.integers(0, 6, 40).astype(float)  # many ties
    for cap in (0, 1, 7, 50):
        rows, best = np.empty((cap, 6), np.int64), np.empty(cap)
        count = 0
        for k, e in enumerate(errs):
            count = kernels.keep_best(rows, best, count, np.array([k, k, k]),
                                      np.array([k, k, k]), e)
        order = np.argsort(errs, kind="stable")[:cap]
        assert count == len(order)
        assert np.array_equal(rows[:count, 0], order) and np.array_equal(best[:count], errs[order])


def test_next_confirmed_finds_the_true_triangle(random_db):
    frame = next(frames(random_db.catalog, random_db.camera, 5, seed=81, noise_px=0.3))
    n, sigma = 6, frame.obs.sigma_rad
    vec = np.ascontiguousarray(frame.obs.vectors[:n])
    tol = 4.0 * np.sqrt(2.0) * sigma
    index = pair_index(random_db.pairs, len(random_db.vectors))
    ang = np.arccos(np.clip(vec @ vec.T, -1, 1))
    windows = np.stack([np.searchsorted(index.angle, ang - tol, "left"),
                        np.searchsorted(index.angle, ang + tol, "right")], axis=-1)
    votes = kernels.angle_votes(index.pi, index.pj, windows, len(random_db.vectors))
    short = votes >= n - 1
    tri = np.array(brightness_triples(n))
    feats = kernels.triple_features(vec, tri, sigma)
    hands = handedness(vec[tri[:, 0]], vec[tri[:, 1]], vec[tri[:, 2]]).astype(np.int64)
    heads = np.full(len(random_db.vectors), -1, np.int64)
    constants = kernels.HybridFrame(tri, feats, hands, ang, tol, 4.0)
    search = kernels.HybridSearch(constants, kernels.ShortPairs(index.pi, index.pj, windows,
                                                                short),
                                  short, random_db.vectors, index.neighbours,
                                  heads, 5, 4)
    t, d, rows = search.next_confirmed(0)
    assert t == 0 and d == 3  # the brightest triple, the next star confirms it
    truth = frame.truth_rows[np.append(tri[0], d)]
    assert any(np.array_equal(row, truth) for row in rows)
    assert search.tested >= 1 and search.fourth_tried == 1 and search.best_kept == 0
    assert np.all(heads == -1)
