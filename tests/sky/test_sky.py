"""Skies: the seeded random sky, the Hipparcos-2 catalog and its cache, and the shared cuts."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from startrack.errors import InputError
from startrack.sky import Catalog, SkySpec, load_sky, merge_close_stars, random_sky
from startrack.sky._hipparcos import (
    CATALOG_EPOCH,
    catalog_file,
    hipparcos_arrays,
    load_hipparcos,
    parse_hip2,
    propagate,
)

SIRIUS = 32349


def _sep_arcsec(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.degrees(np.arccos(np.clip(np.sum(a * b, axis=-1), -1.0, 1.0))) * 3600.0


# --- random sky -------------------------------------------------------------------------


def test_random_sky_is_reproducible_per_seed():
    a, b, c = random_sky(500, seed=3), random_sky(500, seed=3), random_sky(500, seed=4)
    for name in ("ids", "ra_deg", "dec_deg", "mag"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert not np.allclose(a.vectors, c.vectors)


def test_random_sky_ids_and_magnitude_range():
    sky = random_sky(3000, seed=1, mag_min=1.0, mag_max=5.5)
    np.testing.assert_array_equal(np.sort(sky.ids), np.arange(3000))
    assert sky.mag.min() >= 1.0 and sky.mag.max() <= 5.5
    assert np.all(np.diff(sky.mag) >= 0)  # brightest first
    np.testing.assert_allclose(np.linalg.norm(sky.vectors, axis=1), 1.0)


def test_random_sky_is_uniform_on_the_sphere():
    sky = random_sky(20000, seed=7)
    assert np.linalg.norm(sky.vectors.mean(axis=0)) < 0.03
    for axis in range(3):
        assert stats.kstest(sky.vectors[:, axis], stats.uniform(-1, 2).cdf).pvalue > 0.001
    ra_p = stats.kstest(sky.ra_deg, stats.uniform(0, 360).cdf).pvalue
    assert ra_p > 0.001


def test_random_sky_counts_grow_threefold_per_magnitude():
    sky = random_sky(20000, seed=11, mag_min=0.0, mag_max=6.5)
    for m in (3.0, 4.0, 5.0):
        ratio = np.sum(sky.mag < m + 1) / np.sum(sky.mag < m)
        assert 2.6 < ratio < 3.4, (m, ratio)


def test_random_sky_rejects_bad_arguments():
    with pytest.raises(ValueError):
        random_sky(0)
    with pytest.raises(ValueError):
        random_sky(10, mag_min=5.0, mag_max=5.0)


# --- catalog cuts -----------------------------------------------------------------------


def _catalog(ra, dec, mag, ids=None) -> Catalog:
    ids = np.arange(len(ra)) if ids is None else ids
    return Catalog(ids=np.asarray(ids, dtype=np.int64), ra_deg=np.asarray(ra, float),
                   dec_deg=np.asarray(dec, float), mag=np.asarray(mag, float))


def test_merge_close_stars_keeps_the_brighter_of_a_close_pair():
    cat = _catalog([10.0, 10.01, 50.0, 120.0], [0.0, 0.0, 20.0, -40.0], [4.0, 3.0, 5.0, 2.0],
                   ids=[100, 101, 102, 103])
    merged = merge_close_stars(cat, 0.05)
    assert sorted(merged.ids.tolist()) == [101, 102, 103]
    untouched = merge_close_stars(cat, 0.005)
    assert sorted(untouched.ids.tolist()) == [100, 101, 102, 103]
    assert len(merge_close_stars(cat, 0.0)) == 4


def test_merge_close_stars_is_greedy_in_brightness_order():
    # A chain a-b-c with 0.04 deg steps: b goes (near a), so c survives (b no longer blocks it).
    cat = _catalog([10.0, 10.04, 10.08], [0.0, 0.0, 0.0], [1.0, 2.0, 3.0])
    assert merge_close_stars(cat, 0.05).ids.tolist() == [0, 2]


def test_catalog_sorted_and_index_of():
    cat = _catalog([1.0, 2.0, 3.0], [0.0, 0.0, 0.0], [5.0, 1.0, 3.0], ids=[7, 42, 9])
    assert cat.ids.tolist() == [42, 9, 7]
    assert cat.index_of(np.array([7, 42, 9, 8])).tolist() == [2, 0, 1, -1]


def test_skyspec_from_dict_rejects_unknown_keys_and_kinds():
    with pytest.raises(InputError, match="unknown"):
        SkySpec.from_dict({"kind": "random", "nstars": 5})
    with pytest.raises(InputError, match="kind"):
        SkySpec.from_dict({"kind": "tycho"})
    spec = SkySpec.from_dict({"kind": "random", "n_stars": 300, "seed": 2})
    assert SkySpec.from_dict(spec.to_dict()) == spec


def test_load_sky_random_matches_spec():
    sky = load_sky(SkySpec(kind="random", n_stars=400, seed=5, mag_limit=6.0))
    assert len(sky) == 400 and sky.mag.max() <= 6.0
    assert sky.source["seed"] == 5


# --- Hipparcos --------------------------------------------------------------------------


@pytest.fixture(scope="module")
def hip() -> Catalog:
    return load_hipparcos()


def test_hipparcos_has_the_whole_catalog_with_sirius_brightest(hip):
    assert len(hip) >= 117_000
    assert hip.ids.dtype == np.int64 and len(np.unique(hip.ids)) == len(hip)
    assert hip.ids[0] == SIRIUS
    row = hip.index_of(np.array([SIRIUS]))[0]
    assert abs(hip.ra_deg[row] - 101.29) < 0.01
    assert abs(hip.dec_deg[row] - (-16.72)) < 0.01
    assert hip.mag[row] == pytest.approx(-1.0876)
    assert hip.source == {"sky": "hipparcos", "epoch": None}


def test_hipparcos_naked_eye_count_is_plausible(hip):
    n = int(np.sum(hip.mag <= 6.5))
    assert 7_500 < n < 9_500


def test_hipparcos_proper_motion_moves_sirius(hip):
    later = load_hipparcos(epoch=2019.6)
    assert later.source["epoch"] == 2019.6
    a, b = hip.index_of([SIRIUS])[0], later.index_of([SIRIUS])[0]
    moved = _sep_arcsec(hip.vectors[a], later.vectors[b])
    expected = np.hypot(-546.01, -1223.07) / 1000.0 * (2019.6 - CATALOG_EPOCH)
    assert moved == pytest.approx(expected, abs=2.0)
    assert later.dec_deg[b] < hip.dec_deg[a]  # Sirius moves south


def test_propagate_matches_linear_formula_and_leaves_still_stars():
    ra, dec = np.array([30.0, 200.0]), np.array([60.0, -10.0])
    pm_ra, pm_dec = np.array([0.0, 800.0]), np.array([0.0, -300.0])
    new_ra, new_dec = propagate(ra, dec, pm_ra, pm_dec, 25.0)
    assert new_ra[0] == pytest.approx(30.0, abs=1e-12)
    assert new_dec[0] == pytest.approx(60.0, abs=1e-12)
    d_ra = 800.0 / np.cos(np.radians(-10.0)) * 25.0 / 3.6e6
    assert new_ra[1] == pytest.approx(200.0 + d_ra, abs=1e-7)
    assert new_dec[1] == pytest.approx(-10.0 - 300.0 * 25.0 / 3.6e6, abs=1e-7)


def test_propagate_stays_finite_at_the_pole():
    ra, dec = propagate(np.array([0.0]), np.array([90.0]), np.array([1000.0]),
                        np.array([0.0]), 30.0)
    assert np.isfinite(ra).all() and 89.99 < dec[0] < 90.0


def test_load_sky_hipparcos_end_to_end():
    sky = load_sky(SkySpec(kind="hipparcos", mag_limit=6.0, epoch=2019.6,
                           min_separation_deg=0.05))
    cut = int(np.sum(load_hipparcos().mag <= 6.0))
    assert 0.97 * cut < len(sky) < cut  # a few close pairs merged away
    assert sky.mag.max() <= 6.0
    assert sky.source["kind"] == "hipparcos" and sky.source["epoch"] == 2019.6


def test_bad_epoch_is_an_input_error():
    with pytest.raises(InputError):
        load_hipparcos(epoch=float("nan"))
    with pytest.raises(InputError):
        load_hipparcos(epoch="soon")


def test_hipparcos_cache_is_written_reused_and_rebuilt_when_corrupt(tmp_path, monkeypatch):
    monkeypatch.setenv("STARTRACK_CACHE_DIR", str(tmp_path))
    first = hipparcos_arrays()
    files = list(tmp_path.glob("hipparcos-*.npz"))
    assert len(files) == 1
    second = hipparcos_arrays()
    for name in first:
        np.testing.assert_array_equal(first[name], second[name])
    files[0].write_bytes(files[0].read_bytes()[:1000])  # truncated zip
    third = hipparcos_arrays()
    np.testing.assert_array_equal(first["ids"], third["ids"])
    np.testing.assert_array_equal(first["mag"], third["mag"])
    assert files[0].stat().st_size > 1000  # rewritten whole
    assert not list(tmp_path.glob("*.tmp*"))


def test_parse_keeps_only_complete_records(tmp_path):
    lines = catalog_file().read_bytes().splitlines()[:3]
    no_mag = bytearray(lines[1])
    no_mag[129:136] = b" " * 7
    no_pm = bytearray(lines[2])
    no_pm[51:68] = b" " * 17
    path = tmp_path / "hip2.dat"
    path.write_bytes(b"\n".join([lines[0], bytes(no_mag), bytes(no_pm)]) + b"\n")
    arrays = parse_hip2(path)
    assert arrays["ids"].tolist() == [1, 3]
    assert arrays["pm_ra"][1] == 0.0 and arrays["pm_dec"][1] == 0.0


def test_parse_rejects_a_file_in_another_format(tmp_path):
    path = tmp_path / "hip2.dat"
    path.write_text("this is not the Hipparcos catalog\n" * 3)
    with pytest.raises(InputError, match="hip2.dat"):
        parse_hip2(path)
    with pytest.raises(InputError, match="not found"):
        hipparcos_arrays(tmp_path / "missing.dat")
