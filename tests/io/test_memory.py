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
    monkeypatch.setattr(_memory, "resident_bytes", lambda: None)  # unreadable: shed
    assert _memory.shed_memory(above_bytes=2**62)


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
