"""A process gives back the table pages it swept and the heap a build freed."""

from __future__ import annotations

import numpy as np
import pytest

from startrack.io import _memory, _npz
from startrack.io._cache import MAP_MIN_BYTES, cached_arrays

pytestmark = pytest.mark.skipif(_memory.resident_bytes() is None,
                                reason="no /proc/self/statm: resident memory unreadable")


def test_a_swept_mapped_entry_leaves_the_resident_set_when_released(tmp_path, monkeypatch):
    monkeypatch.setenv("STARTRACK_CACHE_DIR", str(tmp_path))
    size = 4 * MAP_MIN_BYTES  # 64 MB: mapped, not read
    cached_arrays("quads", {"t": 1}, lambda: {"a": np.ones(size // 8)})
    mapped = cached_arrays("quads", {"t": 1}, lambda: pytest.fail("rebuilt"))["a"]
    assert isinstance(mapped, np.memmap)
    before = _memory.resident_bytes()
    assert float(mapped.sum()) == size // 8  # every page read
    swept = _memory.resident_bytes()
    assert swept - before > size // 2
    _npz.release_mapped_pages()
    assert _memory.resident_bytes() < swept - size // 2
    assert float(mapped.sum()) == size // 8  # and still read right after


def test_shed_memory_acts_only_above_its_threshold(monkeypatch):
    calls = []
    monkeypatch.setattr(_memory, "release_mapped_pages", lambda: calls.append("pages"))
    monkeypatch.setattr(_memory, "trim_heap", lambda: calls.append("heap"))
    assert not _memory.shed_memory(above_bytes=2**62)
    assert calls == []
    assert _memory.shed_memory(above_bytes=0)
    assert calls == ["pages", "heap"]
    monkeypatch.setattr(_memory, "resident_bytes", lambda: None)  # unreadable: only always
    assert not _memory.shed_memory(above_bytes=0)
    assert _memory.shed_memory()
    assert calls == ["pages", "heap"] * 2


def test_builds_are_left_out_of_the_deadline_clock(tmp_path, monkeypatch):
    """A cache build's seconds do not count against the search's time limit: a first
    use would otherwise time out where a second run solves."""
    import time

    from startrack.io import _cache
    from startrack.solver import _deadline

    monkeypatch.setenv("STARTRACK_CACHE_DIR", str(tmp_path))
    start_clock, start_builds = _deadline.clock(), _cache.build_seconds()
    cached_arrays("merged", {"t": 2}, lambda: (time.sleep(0.3), {"a": np.arange(3)})[1])
    built = _cache.build_seconds() - start_builds
    assert built >= 0.3
    assert _deadline.clock() - start_clock < built


def test_a_build_within_a_build_is_left_out_once(tmp_path, monkeypatch):
    """A table whose build needs another built first: the time left out of the limit is
    the wall time of the outer build, not that plus the inner one (counted twice, the
    solver's clock ran backwards and a 0 ms limit let a first-use search run on)."""
    import time

    from startrack.io import _cache
    from startrack.io._cache import cached_arrays
    from startrack.solver import _deadline

    monkeypatch.setenv("STARTRACK_CACHE_DIR", str(tmp_path))

    def outer():
        cached_arrays("merged", {"t": 4}, lambda: (time.sleep(0.2), {"a": np.arange(2)})[1])
        time.sleep(0.1)
        return {"b": np.arange(3)}

    start_clock, start_builds = _deadline.clock(), _cache.build_seconds()
    t0 = time.perf_counter()
    cached_arrays("merged", {"t": 5}, outer)
    wall = time.perf_counter() - t0
    built = _cache.build_seconds() - start_builds
    assert 0.3 <= built <= wall
    assert _deadline.clock() >= start_clock  # the solver's clock never runs backwards


def test_a_search_sheds_on_its_own_growth_not_on_the_process_size(monkeypatch):
    """A process already holding much (a bench, a compare) keeps the pages of the tables
    it searches; one that the search itself grew past the bound gives them back."""
    from startrack.sky import SkySpec, load_sky
    from startrack.solver import _fov_search

    rng = np.random.default_rng(4)
    x, y = rng.uniform(0, 1024, 30), rng.uniform(0, 1024, 30)  # junk: every window fails
    blind = _fov_search.BlindSolver(load_sky(SkySpec(kind="random")), SkySpec(kind="random"),
                                    0.5, fov_range=(14.0, 34.0))
    blind.solve(x, y, (1024, 1024))  # every table built (a build sheds, whatever the size)
    for growth, sheds in ((0, False), (2 * _fov_search.SHED_GROWTH_BYTES, True)):
        size = [40 * 2**30]  # a big process; each window adds ``growth`` at once
        shed = []

        def resident(size=size, growth=growth):
            size[0] += growth
            return size[0]

        monkeypatch.setattr(_memory, "resident_bytes", resident)
        monkeypatch.setattr(_fov_search, "resident_bytes", resident)
        monkeypatch.setattr(_memory, "release_mapped_pages", lambda shed=shed: shed.append(1))
        monkeypatch.setattr(_memory, "trim_heap", lambda: None)
        assert not blind.solve(x, y, (1024, 1024)).solution.solved
        assert bool(shed) == sheds
    # one frame's searches (Gaia's, then Tycho-2's) share the baseline the pipeline read
    # before the first: the second counts the first's growth too
    monkeypatch.setattr(_fov_search, "resident_bytes", lambda: 40 * 2**30)
    monkeypatch.setattr(_memory, "resident_bytes", lambda: 40 * 2**30)
    shed = []
    monkeypatch.setattr(_memory, "release_mapped_pages", lambda: shed.append(1))
    blind.solve(x, y, (1024, 1024), held_bytes=40 * 2**30)
    assert not shed
    blind.solve(x, y, (1024, 1024), held_bytes=40 * 2**30 - 2 * _fov_search.SHED_GROWTH_BYTES)
    assert shed


def test_blind_solvers_of_one_catalog_share_its_cut_cone_indexes():
    """Blind solvers of one catalog (one per sky and range) used each to build the whole
    catalog's cone index and keep up to 64 MB of its cuts. They index the same stars:
    one set per catalog, and one whole index, the one its databases use."""
    from startrack.sky import SkySpec, load_sky
    from startrack.solver._fov_search import BlindSolver

    catalog = load_sky(SkySpec(kind="random"))
    one = BlindSolver(catalog, SkySpec(kind="random"), 0.5, fov_range=(14.0, 34.0))
    other = BlindSolver(catalog, SkySpec(kind="random"), 1.5, fov_range=(14.0, 34.0))
    assert one._cones() is other._cones()
    # one whole-catalog index, whatever built it first: the databases' and the cuts' own
    from startrack.camera import Camera
    from startrack.database import StarDatabase, held_cone_index

    assert one._cones().whole is held_cone_index(catalog) is StarDatabase(
        catalog, Camera.from_fov(640, 480, 20.0)).cone_index
    assert BlindSolver(load_sky(SkySpec(kind="random", seed=1)), SkySpec(kind="random"),
                       0.5)._cones() is not one._cones()
