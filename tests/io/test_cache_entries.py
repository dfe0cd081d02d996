"""Cache entries are read straight from the .npz, and still rebuilt whenever damaged."""

from __future__ import annotations

import zipfile

import numpy as np
import pytest

from startrack.io._cache import CHECKSUM_KEY, _read_npz, cache_dir, cache_key, cached_arrays


def _arrays() -> dict[str, np.ndarray]:
    rng = np.random.default_rng(7)
    return {"f": rng.random(1000), "i": rng.integers(-5, 5, (300, 3)).astype(np.int32),
            "fortran": np.asfortranarray(rng.random((7, 5))), "empty": np.zeros((0, 3)),
            "scalar": np.array(-1), "text": np.array("héllo"), "b": rng.random(9) > 0.5}


def test_direct_read_equals_np_load(tmp_path):
    path = tmp_path / "e.npz"
    np.savez(path, **_arrays())
    got = _read_npz(path)
    with np.load(path) as want:
        assert sorted(got) == sorted(want.files)
        for name in want.files:
            assert got[name].dtype == want[name].dtype
            assert got[name].shape == want[name].shape
            np.testing.assert_array_equal(got[name], want[name])
            assert got[name].flags.writeable and got[name].flags.aligned
    assert got["fortran"].flags.f_contiguous


def _entry(tmp_path, monkeypatch, build):
    monkeypatch.setenv("STARTRACK_CACHE_DIR", str(tmp_path))
    cached_arrays("t", {"k": 1}, build)
    return cache_dir() / f"{cache_key('t', {'k': 1})}.npz"


def _counting_build():
    calls = []

    def build():
        calls.append(1)
        return {"a": np.arange(50_000, dtype=np.float64), "b": np.arange(7, dtype=np.int32)}

    return build, calls


def test_a_flipped_byte_inside_the_data_is_rebuilt(tmp_path, monkeypatch):
    # The zip's own CRC is not checked on the direct read: the hash must catch it.
    build, calls = _counting_build()
    path = _entry(tmp_path, monkeypatch, build)
    blob = bytearray(path.read_bytes())
    with zipfile.ZipFile(path) as zf:
        info = zf.getinfo("a.npy")
    blob[info.header_offset + 30 + len("a.npy") + 300_000] ^= 0x10  # inside a's data
    path.write_bytes(bytes(blob))
    out = cached_arrays("t", {"k": 1}, build)
    assert len(calls) == 2
    np.testing.assert_array_equal(out["a"], np.arange(50_000, dtype=np.float64))
    assert _read_npz(path)["a"].tobytes() == out["a"].tobytes()  # rewritten whole


@pytest.mark.parametrize("cut", [10, 1000, -10])
def test_a_truncated_entry_is_rebuilt(tmp_path, monkeypatch, cut):
    build, calls = _counting_build()
    path = _entry(tmp_path, monkeypatch, build)
    path.write_bytes(path.read_bytes()[:cut])
    cached_arrays("t", {"k": 1}, build)
    assert len(calls) == 2


def test_a_member_whose_header_disagrees_with_its_size_is_rebuilt(tmp_path, monkeypatch):
    build, calls = _counting_build()
    path = _entry(tmp_path, monkeypatch, build)
    blob = path.read_bytes().replace(b"(50000,)", b"(49999,)", 1)
    path.write_bytes(blob)
    cached_arrays("t", {"k": 1}, build)
    assert len(calls) == 2


def test_a_compressed_entry_with_a_good_checksum_is_used(tmp_path, monkeypatch):
    build, calls = _counting_build()
    path = _entry(tmp_path, monkeypatch, build)
    with np.load(path) as data:
        stored = {name: data[name] for name in data.files}
    assert CHECKSUM_KEY in stored
    np.savez_compressed(path, **stored)
    out = cached_arrays("t", {"k": 1}, build)
    assert len(calls) == 1
    np.testing.assert_array_equal(out["b"], np.arange(7, dtype=np.int32))


def test_an_entry_of_another_catalog_copied_over_is_rebuilt(tmp_path, monkeypatch):
    # Issue 31: the Gaia parse entry (same array names, a valid checksum) copied over the
    # Hipparcos one was trusted, and Gaia source ids were reported as HIP numbers.
    from startrack.sky import gaia_arrays, hipparcos_arrays

    monkeypatch.setenv("STARTRACK_CACHE_DIR", str(tmp_path))
    hip = hipparcos_arrays()
    gaia_arrays()
    entries = {p.name.split("-")[0]: p for p in tmp_path.glob("*.npz")}
    entries["hipparcos"].write_bytes(entries["gaia"].read_bytes())
    again = hipparcos_arrays()
    np.testing.assert_array_equal(again["ids"], hip["ids"])
    assert again["ids"].max() <= 120_404  # HIP numbers, not Gaia source ids
    assert _read_npz(entries["hipparcos"])["ids"].shape == hip["ids"].shape  # rewritten


def test_an_entry_whose_stored_key_differs_is_rebuilt(tmp_path, monkeypatch):
    build, calls = _counting_build()
    path = _entry(tmp_path, monkeypatch, build)
    other = cache_dir() / f"{cache_key('t', {'k': 2})}.npz"
    cached_arrays("t", {"k": 2}, lambda: {"a": np.zeros(3), "b": np.ones(2, np.int32)})
    path.write_bytes(other.read_bytes())  # valid checksum, another key
    out = cached_arrays("t", {"k": 1}, build)
    assert len(calls) == 2
    np.testing.assert_array_equal(out["b"], np.arange(7, dtype=np.int32))


def test_cache_help_states_the_cap_the_code_applies():
    """`startrack cache --help` said 1024 MB while the cap was 2048 (found by QA)."""
    from click.testing import CliRunner

    from startrack.cli import main
    from startrack.io._cache import DEFAULT_CACHE_MAX_MB

    text = " ".join(CliRunner().invoke(main, ["cache", "--help"]).output.split())
    assert f"megabytes (default {DEFAULT_CACHE_MAX_MB})" in text
