"""The shared matcher toolkit: compiled pair joins against brute force (rows and their
order), sorted-key joins, triple orders and handedness."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from startrack.database import build_pair_arrays, pair_table_from_arrays
from startrack.match_records import MatchDiagnostics
from startrack.matchers._shared.geometry import handedness, triple_products
from startrack.matchers._shared.pair_joins import (
    PairLookup,
    join_close,
    join_extend,
    join_sorted,
    member_pairs,
    pair_index,
)
from startrack.matchers._shared.triples import brightness_triples, smart_triples, triple_order


def _sky(n: int = 40, seed: int = 5) -> np.ndarray:
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(n, 3)) * np.array([0.3, 0.3, 1.0]) + np.array([0.0, 0.0, 2.0])
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _lookup(vectors: np.ndarray, observed: np.ndarray, tol: float):
    table = pair_table_from_arrays(build_pair_arrays(vectors, 0.6))
    return table, PairLookup(pair_index(table, len(vectors)), observed, tol, MatchDiagnostics())


def _reference_pairs(table, lo: float, hi: float, flip: bool) -> tuple[np.ndarray, ...]:
    """Both orientations of the window's pairs, grouped by first star in stable order."""
    sel = (table.angle >= lo) & (table.angle <= hi)
    i, j = table.i[sel].astype(np.int64), table.j[sel].astype(np.int64)
    if flip:
        i, j = j, i
    cp, cq = np.concatenate([i, j]), np.concatenate([j, i])
    order = np.argsort(cp, kind="stable")
    return cp[order], cq[order]


def test_join_extend_equals_the_stable_sort_join():
    vectors = _sky()
    observed = vectors[[3, 8, 17]]
    table, lookup = _lookup(vectors, observed, 0.02)
    rng = np.random.default_rng(1)
    hyps = rng.integers(0, len(vectors), size=(60, 2))
    for p, q in ((1, 2), (2, 1)):
        lo, hi = lookup.window(p, q)
        cp, cq = _reference_pairs(table, lo, hi, flip=p > q)
        want = [(*h, b) for h in hyps.tolist() for a, b in zip(cp, cq, strict=True)
                if a == h[1] and b not in h]
        got, total = join_extend(hyps, 1, lookup, p, q)
        assert [tuple(r) for r in got.tolist()] == want
        assert total == len(want)
    assert join_extend(hyps[:0], 0, lookup, 1, 2)[0].shape == (0, 3)


def test_join_extend_stops_at_max_rows_but_counts_all():
    vectors = _sky()
    _, lookup = _lookup(vectors, vectors[[3, 8]], 0.1)
    hyps = np.arange(len(vectors)).reshape(-1, 1)
    full, total = join_extend(hyps, 0, lookup, 0, 1)
    some, total_again = join_extend(hyps, 0, lookup, 0, 1, max_rows=3)
    assert total == total_again == len(full) > 3
    np.testing.assert_array_equal(some, full[:3])


def test_join_close_equals_brute_force():
    vectors = _sky()
    observed = vectors[[2, 5, 11]]
    table, lookup = _lookup(vectors, observed, 0.03)
    lo, hi = lookup.window(0, 2)
    sel = (table.angle >= lo) & (table.angle <= hi)
    allowed = set(zip(table.i[sel].tolist(), table.j[sel].tolist(), strict=True))
    allowed |= {(b, a) for a, b in allowed}
    rng = np.random.default_rng(6)
    hyps = rng.integers(0, len(vectors), size=(400, 3))
    hyps = np.vstack([hyps, [[2, 0, 11], [11, 1, 2]]])
    got = join_close(hyps, 0, 2, lookup, 0, 2)
    want = [h for h in hyps.tolist() if (h[0], h[2]) in allowed]
    assert got.tolist() == want and len(want) >= 2


def test_lookup_counts_first_lookups_only():
    vectors = _sky()
    table, lookup = _lookup(vectors, vectors[[2, 5]], 0.03)
    lookup.pairs(0, 1)
    lookup.pairs(1, 0)
    lo, hi = lookup.window(0, 1)
    assert lookup.diag.candidates == int(np.count_nonzero((table.angle >= lo)
                                                          & (table.angle <= hi)))
    assert lookup.diag.extra["lookups"] == 1
    np.testing.assert_array_equal(lookup.pairs(1, 0), lookup.pairs(0, 1)[:, ::-1])


def test_join_sorted_equals_brute_force():
    rng = np.random.default_rng(8)
    left = rng.integers(0, 9, size=(50, 3))
    right = rng.integers(0, 9, size=(70, 3))
    got = join_sorted(left, (1, 2), right)
    want = [(*h, r[2]) for h in left.tolist() for r in right.tolist()
            if (r[0], r[1]) == (h[1], h[2]) and r[2] not in h]
    assert sorted(map(tuple, got.tolist())) == sorted(want)
    assert join_sorted(left, (0,), right[:0]).shape == (0, 4)
    keep = member_pairs(left[:, 0], left[:, 1], right[:, :2])
    pairs = set(map(tuple, right[:, :2].tolist()))
    assert keep.tolist() == [(a, b) in pairs for a, b in left[:, :2].tolist()]


def test_triple_orders_cover_every_triple_once():
    for n in range(3, 10):
        assert sorted(smart_triples(n)) == list(itertools.combinations(range(n), 3))
        assert sorted(brightness_triples(n)) == list(itertools.combinations(range(n), 3))
    first = list(smart_triples(8))[:6]
    # Star 0 drops out of the tries at once: the second triple avoids it.
    assert first[0] == (0, 1, 2) and 0 not in first[1]
    order = triple_order(5, 8, 1000)
    assert sorted(order) == list(itertools.combinations(range(8), 3))
    assert all(max(t) < 5 for t in order[:10]) and len(triple_order(5, 8, 7)) == 7


def test_triple_product_sign_flips_in_a_mirror():
    rng = np.random.default_rng(4)
    v = rng.normal(size=(3, 20, 3))
    v /= np.linalg.norm(v, axis=2, keepdims=True)
    mirror = v * np.array([-1.0, 1.0, 1.0])
    np.testing.assert_allclose(triple_products(*mirror), -triple_products(*v))
    np.testing.assert_allclose(triple_products(*v), np.linalg.det(np.stack(v, axis=1)))
    np.testing.assert_array_equal(handedness(*mirror), -handedness(*v))


def test_timeout_gives_a_not_solved_with_its_reason(random_db):
    from synth import frames, prepared_matcher

    from startrack.solver import identify

    matcher = prepared_matcher("pyramid", random_db)
    frame = next(frames(random_db.catalog, random_db.camera, 5, seed=71, noise_px=0.3))
    assert identify(frame.obs, matcher, timeout_ms=None).solved
    late = identify(frame.obs, matcher, timeout_ms=0.0)
    assert not late.solved and late.reason == "timeout" and late.rotation is None
    few = identify(type(frame.obs).from_pixels(frame.obs.x[:2], frame.obs.y[:2],
                                                frame.obs.camera, 0.3), matcher)
    assert few.reason == "too_few_stars"


@pytest.mark.parametrize("radius, spread", [(4.0, 50.0), (1.0, 1000.0), (30.0, 1000.0),
                                            (3000.0, 1000.0), (4.0, 0.0)])
def test_nearest_matches_keep_the_nearest_claim(radius, spread):
    """The grid search gives the brute-force answer: each observed star its nearest
    catalog star within the radius (the lower index on a tie), each catalog star kept by
    its nearest claimant (the lower observed index on a tie)."""
    from startrack._core.verify.nearest import matches as nearest_matches

    rng = np.random.default_rng(int(radius + spread))
    ox, oy = rng.uniform(0, spread, 40), rng.uniform(0, spread, 40)
    cx, cy = rng.uniform(0, spread, 30), rng.uniform(0, spread, 30)
    cx[5], cy[5] = cx[4], cy[4]  # a catalog star twice: ties on the observed side
    ox[7], oy[7] = ox[6], oy[6]  # an observed star twice: ties on the catalog side
    ox[:3], oy[:3] = cx[:3] + 0.5, cy[:3] - 0.25
    rows, pos = nearest_matches(ox, oy, cx, cy, radius)
    d2 = (ox[:, None] - cx[None, :]) ** 2 + (oy[:, None] - cy[None, :]) ** 2
    near = np.argmin(d2, axis=1)  # argmin: the first on a tie
    want = []
    for i in range(len(ox)):
        j = int(near[i])
        rivals = [k for k in range(len(ox)) if near[k] == j and d2[k, j] <= radius**2]
        if d2[i, j] <= radius**2 and min(rivals, key=lambda k: (d2[k, j], k)) == i:
            want.append((i, j))
    assert list(zip(rows.tolist(), pos.tolist(), strict=True)) == want and want
    assert len(set(pos.tolist())) == len(pos)


@pytest.mark.parametrize("radius2", [0.0, 9.0, 400.0, 1e8, np.inf, -1.0, np.nan])
def test_pairs_within_is_the_brute_force_list(radius2):
    """The pair search lists exactly the pairs a full observed x catalog table keeps, by
    observed then catalog index; NaN positions pair with nothing."""
    from startrack._core.verify.nearest import pairs as pairs_within

    rng = np.random.default_rng(17)
    cx, cy = rng.uniform(0, 200, 60), rng.uniform(0, 200, 60)
    ox, oy = np.concatenate([cx[:30] + rng.normal(0, 2, 30), rng.uniform(0, 200, 20)]), \
        np.concatenate([cy[:30] + rng.normal(0, 2, 30), rng.uniform(0, 200, 20)])
    cx[7], ox[3], oy[9] = np.nan, np.nan, np.nan
    ox[4], oy[4] = cx[4], cy[4]  # an exact coincidence: distance 0
    obs, cat, d2, start = pairs_within(ox, oy, cx, cy, radius2)
    full = (ox[:, None] - cx[None, :]) ** 2 + (oy[:, None] - cy[None, :]) ** 2
    want_obs, want_cat = np.nonzero(full <= radius2)  # row-major: observed, then catalog
    np.testing.assert_array_equal(obs, want_obs)
    np.testing.assert_array_equal(cat, want_cat)
    np.testing.assert_array_equal(d2, full[want_obs, want_cat])
    np.testing.assert_array_equal(start, np.searchsorted(want_obs, np.arange(len(ox) + 1)))


@pytest.mark.parametrize("k1", [0.0, -0.3, 0.2])
def test_compiled_projection_is_the_cameras(k1):
    """Verification projects through the compiled kernel; it must land every catalog
    vector where Camera.vector_to_pixel and in_image put it, lens included."""
    from startrack._core.verify.entry_points import project

    from startrack.camera import Camera, RadialDistortion
    from startrack.verify._frame import camera_geometry

    camera = Camera.from_fov(1024, 768, 20.0, distortion=RadialDistortion(k1=k1))
    rng = np.random.default_rng(int(abs(k1) * 10) + 3)
    vectors = rng.normal(size=(4000, 3))
    vectors[:, 2] = np.abs(vectors[:, 2]) * 8.0 - 0.5  # most in front, some behind
    vectors /= np.linalg.norm(vectors, axis=1, keepdims=True)
    matrix = Rotation.random(random_state=rng).as_matrix()
    sky = vectors @ matrix.T  # catalog vectors whose camera-frame directions are `vectors`
    for margin in (-3.0, 0.0, 40.0):
        px, py, inside = project(sky, matrix, camera_geometry(camera), margin)
        x, y, front = camera.vector_to_pixel(vectors)
        want = front & camera.in_image(x, y, margin=-margin)
        np.testing.assert_array_equal(inside, want)
        np.testing.assert_allclose(px[want], x[want], rtol=0, atol=1e-9)
        np.testing.assert_allclose(py[want], y[want], rtol=0, atol=1e-9)
        assert 100 < np.count_nonzero(inside) < len(vectors)


def test_compiled_wahba_and_quaternion_agree_with_scipy():
    from startrack._core.shared import matrix_to_quaternion, wahba

    from startrack.attitude import wahba_matrices

    rng = np.random.default_rng(17)
    for _ in range(50):
        truth = Rotation.random(random_state=rng)
        cam = rng.normal(size=(int(rng.integers(2, 30)), 3))
        cam /= np.linalg.norm(cam, axis=1, keepdims=True)
        sky = truth.apply(cam) + rng.normal(scale=1e-4, size=cam.shape)
        m = wahba(cam, sky)
        np.testing.assert_allclose(m, wahba_matrices(cam, sky), atol=1e-9)
        q = matrix_to_quaternion(m)
        want = Rotation.from_matrix(m).as_quat()
        want = -want if want[3] < 0 else want
        np.testing.assert_allclose(q, want, atol=1e-12)
    # Every branch of the quaternion (trace or one diagonal element largest).
    for angle_axis in ([np.pi * 0.9, 0, 0], [0, np.pi * 0.9, 0], [0, 0, np.pi * 0.9], [0.1, 0, 0]):
        r = Rotation.from_rotvec(angle_axis)
        q = matrix_to_quaternion(r.as_matrix())
        assert Rotation.from_quat(q).approx_equal(r, atol=1e-12)


def _random_frames(seed, count, scales):
    """Catalog and observed positions at every scale: ties (rounded positions), stars
    near their catalog star and stars anywhere, some off the catalog's extent."""
    rng = np.random.default_rng(seed)
    for t in range(count):
        m, n = int(rng.integers(1, 60)), int(rng.integers(0, 60))
        scale = scales[t % len(scales)]
        cx, cy = rng.uniform(0, scale, m), rng.uniform(0, scale, m)
        if t % 3 == 0:
            cx, cy = np.round(cx), np.round(cy)
        k = min(m, n)
        ox = np.concatenate([cx[:k] + rng.normal(0, scale / 100, k),
                             rng.uniform(-0.1 * scale, 1.1 * scale, n - k)])
        oy = np.concatenate([cy[:k] + rng.normal(0, scale / 100, k),
                             rng.uniform(-0.1 * scale, 1.1 * scale, n - k)])
        yield t, rng, scale, cx, cy, ox, oy


def test_pairs_within_grid_is_the_brute_force_scan():
    """The grid search lists what a scan of every pair lists, on frames at every scale,
    with rounded (tied) positions, NaN and infinite coordinates and radii on the
    boundary."""
    from startrack._core.verify.nearest import pairs as pairs_within

    for t, rng, scale, cx, cy, ox, oy in _random_frames(23, 3000, (1.0, 200.0, 1e6, 1e-3)):
        m, n = len(cx), len(ox)
        if t % 5 == 0:
            cx[rng.integers(m)] = np.nan
        if t % 7 == 0 and n:
            ox[rng.integers(n)] = np.nan
        if t % 11 == 0 and n:
            ox[rng.integers(n)] = np.inf
        if t % 17 == 0:
            cy[rng.integers(m)] = np.inf
        radius2 = (0.0, (scale / 50) ** 2, (scale / 10) ** 2, (scale * 5) ** 2, -1.0)[t % 5]
        if t % 19 == 0 and n:
            ox[0], oy[0], radius2 = cx[0] + scale / 50, cy[0], (scale / 50) ** 2
        with np.errstate(invalid="ignore"):
            full = (ox[:, None] - cx[None, :]) ** 2 + (oy[:, None] - cy[None, :]) ** 2
        want_obs, want_cat = np.nonzero(full <= radius2)
        got = pairs_within(ox, oy, cx, cy, radius2)
        for a, b in zip(got, (want_obs, want_cat, full[want_obs, want_cat],
                              np.searchsorted(want_obs, np.arange(n + 1))), strict=True):
            np.testing.assert_array_equal(a, b)


def test_nearest_scanning_only_the_reached_cells_is_the_brute_force_scan():
    """Scanning only the cells a star's radius reaches finds each star's nearest catalog
    star within the radius (the lower index on a tie), at every scale, with ties,
    rounded positions and stars off the catalog's extent."""
    from startrack._core.verify.nearest import nearest

    for t, _, scale, cx, cy, ox, oy in _random_frames(29, 3000, (1.0, 1024.0, 1e5, 1e-2)):
        radius = (0.0, scale / 100, scale / 20, 3 * scale)[t % 4]
        found, dist2 = nearest(ox, oy, cx, cy, radius)
        d2 = (ox[:, None] - cx[None, :]) ** 2 + (oy[:, None] - cy[None, :]) ** 2
        best = np.argmin(d2, axis=1) if len(cx) else np.zeros(len(ox), np.int64)
        best_d = d2[np.arange(len(ox)), best] if len(cx) else np.full(len(ox), np.inf)
        hit = best_d <= radius * radius
        np.testing.assert_array_equal(found, np.where(hit, best, -1))
        np.testing.assert_array_equal(dist2, np.where(hit, best_d, np.inf))
