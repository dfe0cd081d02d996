"""The compiled build and parse kernels give exactly numpy's answers, bit for bit."""

from __future__ import annotations

import math

import numpy as np
import pytest
from startrack._core.database.pair_tables import PairNeighbours

from startrack._core.database import builds as kernels
from startrack._core.sky import close_pairs, parse
from startrack.database import _pairs as database_pairs
from startrack.database._kvector import KVector
from startrack.database._pairs import THREADED_PAIRS, build_pair_arrays, build_threads
from startrack.sky import random_sky


def test_merge_counts_are_searchsorted():
    rng = np.random.default_rng(5)
    for s in (np.sort(rng.uniform(0, 1, 5000)), np.repeat(np.linspace(0, 1, 9), 30),
              np.full(40, 0.5), np.array([0.3])):
        table = KVector.build(s)
        z = table.m * np.arange(len(s), dtype=np.float64) + table.q
        np.testing.assert_array_equal(table.k, np.searchsorted(s, z, side="right"))
    assert kernels.is_sorted(np.array([0.0, 0.0, 1.0]))
    assert not kernels.is_sorted(np.array([0.0, 1.0, 0.5]))
    with pytest.raises(ValueError):
        KVector.build(np.array([0.2, 0.1]))


def test_keyed_bucket_sort_on_ties_and_clusters():
    rng = np.random.default_rng(9)
    values = np.concatenate([rng.normal(0.2, 1e-7, 2000), np.full(300, 0.7),
                             rng.uniform(0, 1, 3000)]).clip(0, 1)
    rng.shuffle(values)
    np.testing.assert_array_equal(kernels.stable_argsort(values, 0.0, 1.0),
                                  np.argsort(values, kind="stable"))


def test_pair_build_equals_brute_force():
    sky = random_sky(600, seed=4)
    arrays = build_pair_arrays(sky.vectors, math.radians(15.0))
    cos = np.clip(sky.vectors @ sky.vectors.T, -1, 1)
    i, j = np.triu_indices(len(sky), 1)
    close = cos[i, j] >= math.cos(math.radians(15.0))
    assert arrays["i"].dtype == arrays["j"].dtype == np.int32
    assert len(arrays["angle"]) == close.sum()
    assert np.all(np.diff(arrays["angle"]) >= 0) and np.all(arrays["i"] < arrays["j"])
    got = set(zip(arrays["i"].tolist(), arrays["j"].tolist(), strict=True))
    assert got == set(zip(i[close].tolist(), j[close].tolist(), strict=True))
    np.testing.assert_allclose(arrays["angle"], np.arccos(cos[arrays["i"], arrays["j"]]),
                               atol=1e-12)


def _sweep_order_reference(vectors: np.ndarray, max_angle: float):
    """The pairs in the order the z sweep meets them, then stably sorted by angle."""
    order = np.argsort(vectors[:, 2], kind="stable")
    x, y, z = vectors[order].T
    a, b = np.triu_indices(len(vectors), 1)
    d = x[a] * x[b] + y[a] * y[b] + z[a] * z[b]  # the kernel's sum, in its order
    keep = d >= math.cos(max_angle)
    # math.acos is the C library's, as the kernel's; numpy's arccos may round otherwise.
    angle = np.array([math.acos(v) for v in np.clip(d[keep], -1.0, 1.0)])
    a, b = a[keep], b[keep]
    first = np.argsort(angle, kind="stable")
    i, j = order[a[first]], order[b[first]]
    return np.minimum(i, j), np.maximum(i, j), angle[first]


@pytest.mark.parametrize("copies", [1, 3])
def test_pair_build_keeps_the_sweep_order_among_equal_angles(copies):
    # Repeated stars make many pairs of exactly equal angle, and the table's order among
    # them must not depend on how the build buckets them.
    sky = np.repeat(random_sky(300, seed=7).vectors, copies, axis=0)
    arrays = build_pair_arrays(sky, math.radians(25.0))
    for got, want in zip((arrays["i"], arrays["j"], arrays["angle"]),
                         _sweep_order_reference(sky, math.radians(25.0)), strict=True):
        np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("threads", [2, 3, 7])
def test_a_pair_build_split_among_threads_is_the_same_table(threads):
    # each thread sweeps its own first stars and writes after the threads before it in
    # every bucket: the same order, ties included, as one sweep
    sky = np.repeat(random_sky(300, seed=7).vectors, 3, axis=0)
    got = close_pairs.sorted_close_pairs(sky, math.radians(25.0), threads)
    for a, b in zip(got, _sweep_order_reference(sky, math.radians(25.0)), strict=True):
        np.testing.assert_array_equal(a, b)
    few = close_pairs.sorted_close_pairs(sky[:2], math.radians(25.0), threads)
    assert [len(a) for a in few] == [1, 1, 1]


def test_neighbour_lists_built_in_two_threads_are_the_same():
    sky = random_sky(800, seed=3)
    arrays = build_pair_arrays(sky.vectors, math.radians(12.0))
    one, two = (PairNeighbours(arrays["i"], arrays["j"], arrays["angle"], len(sky),
                               threaded=threaded) for threaded in (False, True))
    for a, b in zip(one.lists, two.lists, strict=True):
        assert a.dtype == b.dtype
        np.testing.assert_array_equal(a, b)
    start_lo, nbr_lo = one.lists[:2]
    star = int(arrays["i"][0])  # its partners as first star, in table order
    np.testing.assert_array_equal(nbr_lo[start_lo[star]:start_lo[star + 1]],
                                  arrays["j"][arrays["i"] == star])


@pytest.mark.parametrize(("cores", "threads"), [(1, 1), (4, 4), (16, 8)])
def test_only_a_large_table_is_built_in_threads(monkeypatch, cores, threads):
    # the machine's cores faked: one thread below the threshold, else one a core, at most 8
    monkeypatch.setattr(database_pairs, "usable_cores", lambda: cores)
    assert build_threads(THREADED_PAIRS - 1) == 1
    assert build_threads(THREADED_PAIRS) == threads


def test_pair_build_of_no_pairs_and_of_one_star():
    for sky in (random_sky(50, seed=1).vectors[:1], np.empty((0, 3))):
        arrays = build_pair_arrays(sky, 0.1)
        assert len(arrays["i"]) == len(arrays["j"]) == len(arrays["angle"]) == 0


def test_take_applies_the_order():
    rng = np.random.default_rng(2)
    order = rng.permutation(500)
    rows, area, polar = rng.integers(0, 99, (500, 3)), rng.random(500), rng.random(500)
    tr, ta, tp = kernels.take_triangles(order, rows, area, polar)
    np.testing.assert_array_equal(tr, rows[order].astype(np.int32))
    assert tr.dtype == np.int32
    np.testing.assert_array_equal(ta, area[order])
    np.testing.assert_array_equal(tp, polar[order])


def _field_bytes(texts: list[str], width: int) -> np.ndarray:
    return np.array([t.rjust(width).encode() for t in texts],
                    dtype=f"S{width}").view(np.uint8).reshape(len(texts), width)


def test_decimal_fields_are_parsed_as_numpy_parses_them():
    rng = np.random.default_rng(11)
    texts = [f"{x:.{d}f}" for x, d in zip(rng.normal(0, 300, 3000), rng.integers(0, 11, 3000),
                                          strict=True)]
    texts += ["-0.00", "0", "+1.5", "123456789012345", "0.0000159148", "-.5", "7."]
    raw = _field_bytes(texts, 16)
    values, ok = parse.decimal_column(raw, 0, 16)
    assert ok
    want = np.array(texts, dtype="S16").astype(np.float64)
    assert values.tobytes() == want.tobytes()  # bit for bit, signed zero included
    blank, _ = parse.decimal_column(_field_bytes(["", "1.0"], 6), 0, 6)
    assert np.isnan(blank[0]) and blank[1] == 1.0


@pytest.mark.parametrize("text", ["1e5", "nan", "1.2.3", "12345678901234567", "-", "1\t"])
def test_other_fields_are_left_to_the_general_parser(text):
    _, ok = parse.decimal_column(_field_bytes([text, "2.0"], 20), 0, 20)
    assert not ok


def test_records_need_one_line_length():
    assert parse.records(b"abcd\nefgh\n", 3).shape == (2, 4)
    assert parse.records(b"abcd\nefgh", 3).shape == (2, 4)  # no final newline
    assert parse.records(b"abcd\nefg\n", 3) is None
    assert parse.records(b"ab\ncd\n", 3) is None  # shorter than a record
    raw = parse.records(b"abcd\n    \nefgh\n", 3)
    assert parse.blank_rows(raw).tolist() == [False, True, False]


def test_a_pair_table_read_back_from_the_cache_maps_its_stored_lists():
    # Issue 49: the k-vector and neighbour lists took a third of a second of every
    # identify; they are stored beside the table and read, equal to the ones built
    from startrack.camera import Camera
    from startrack.database import StarDatabase
    from startrack.matchers._shared.pair_joins import pair_index

    sky, camera = random_sky(600, seed=5), Camera.from_fov(1024, 1024, 15.0)
    first = StarDatabase(sky, camera).pairs  # built and stored
    table = StarDatabase(sky, camera).pairs  # read back
    assert table.lists is not None and table.lists[0] == len(sky)
    np.testing.assert_array_equal(table.angle, first.angle)
    built = PairNeighbours(table.i, table.j, table.angle, len(sky))
    index = pair_index(table, len(sky))
    for stored, fresh in zip(index.lists, built.lists, strict=True):
        np.testing.assert_array_equal(stored, fresh)
    assert index.lists[1] is table.lists[1][1]  # taken as stored, not rebuilt
    fresh_k = KVector.build(table.angle)
    np.testing.assert_array_equal(table.kvector.k, fresh_k.k)
    assert (table.kvector.m, table.kvector.q) == (fresh_k.m, fresh_k.q)
    other = pair_index(table, len(sky) + 1)  # another catalog size: built for it
    assert len(other.lists[0]) == len(sky) + 2
    with pytest.raises(ValueError, match="another table"):
        PairNeighbours(table.i, table.j, table.angle, len(sky) + 1, lists=index.lists)


def test_pattern_keys_are_numpys_keys_and_ratios():
    """The compiled keys and stored ratios of a level's patterns are numpy's, bit for bit,
    from patterns a few arcmin wide to a hemisphere's."""
    from startrack._core.database.quad_table import pattern_keys

    from startrack.database._quads import BIN, EDGES, NBINS, RATIO_STEPS
    from tests.matchers.quad_reference import edge_angles, keys_of, ratios

    rng = np.random.default_rng(3)
    for spread in (1e-3, 1e-2, 0.3, 2.0):
        centre = rng.normal(size=3)
        v = centre / np.linalg.norm(centre) + spread * rng.normal(size=(3000, 3))
        v = np.ascontiguousarray(v / np.linalg.norm(v, axis=1)[:, None])
        quads = np.array([rng.choice(len(v), 4, replace=False) for _ in range(4000)])
        quads[:5, 1] = quads[:5, 0]  # a repeated star: a zero edge
        r, _ = ratios(edge_angles(v, quads))
        keys, stored = pattern_keys(v, quads, EDGES, BIN, NBINS, float(RATIO_STEPS))
        np.testing.assert_array_equal(keys, keys_of(r).astype(np.int32))
        np.testing.assert_array_equal(stored, np.round(r * RATIO_STEPS).astype(np.uint8))
