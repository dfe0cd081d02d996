"""The compiled kernels' cache folder follows the sources: any change to a file that
defines kernels (a callee's included) gives a fresh folder; the last few are kept."""

from __future__ import annotations

import os
import subprocess
import sys
import time

from startrack import _numba_cache


def _tree(root):
    (root / "sub").mkdir(parents=True)
    (root / "__pycache__").mkdir()
    for name in ("a.py", "sub/b.py", "__pycache__/x.nbi", "data.txt"):
        (root / name).write_text("from numba import njit\n")
    (root / "plain.py").write_text("x = 1\n")  # no kernel: its changes do not count
    return root


def test_stamp_changes_with_any_kernel_source_and_nothing_else(tmp_path):
    root = _tree(tmp_path / "pkg")
    first = _numba_cache._source_stamp(root)
    assert _numba_cache._source_stamp(root) == first
    (root / "__pycache__" / "x.nbi").write_text("compiled, changed")  # not a source
    (root / "data.txt").write_text("other")
    (root / "plain.py").write_text("x = 2\n")
    later = time.time() + 5
    os.utime(root / "a.py", (later, later))  # touched, same contents
    assert _numba_cache._source_stamp(root) == first
    (root / "sub" / "b.py").write_text("from numba import njit  # a callee edited\n")
    assert _numba_cache._source_stamp(root) != first


def test_prune_keeps_the_most_recently_used(tmp_path):
    for k in range(_numba_cache.KEEP + 3):
        folder = tmp_path / f"{_numba_cache.PREFIX}{k}"
        folder.mkdir()
        os.utime(folder, (1000 + k, 1000 + k))
    _numba_cache._prune(tmp_path)
    left = sorted(p.name for p in tmp_path.iterdir())
    assert left == [f"{_numba_cache.PREFIX}{k}" for k in range(3, _numba_cache.KEEP + 3)]


def test_prune_spares_folders_in_use(tmp_path):
    now = time.time()
    recent = _numba_cache.KEEP + 2  # more folders used within the day than KEEP
    for k in range(recent + 3):
        folder = tmp_path / f"{_numba_cache.PREFIX}{k}"
        folder.mkdir()
        age = 60.0 * (k + 1) if k < recent else 10 * 86400.0 + k
        os.utime(folder, (now - age, now - age))
    _numba_cache._prune(tmp_path)
    left = sorted(p.name for p in tmp_path.iterdir())
    assert left == sorted(f"{_numba_cache.PREFIX}{k}" for k in range(recent))


def _cache_dirs(tmp_path, imports: str, explicit: str | None = None) -> list[str]:
    """NUMBA_CACHE_DIR and numba's own setting in a fresh interpreter after ``imports``."""
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["XDG_CACHE_HOME"] = str(tmp_path)
    if explicit is not None:
        env["NUMBA_CACHE_DIR"] = explicit
    code = (f"import {imports}, os, numba.core.config as c; "
            "print(os.environ['NUMBA_CACHE_DIR']); print(c.CACHE_DIR)")
    return subprocess.run([sys.executable, "-c", code], env=env, text=True,
                          capture_output=True, check=True).stdout.split()


def test_import_points_numba_at_the_versioned_folder(tmp_path):
    out = _cache_dirs(tmp_path, "startrack")
    assert out[0] == out[1] and out[0].startswith(str(tmp_path / "startrack" / "numba"))
    assert _cache_dirs(tmp_path, "startrack", str(tmp_path / "mine")) == [
        str(tmp_path / "mine")] * 2


def test_numba_imported_first_still_uses_the_versioned_folder(tmp_path):
    """A script that imports numba before startrack (numba has read its settings by then)
    still caches startrack's kernels in the versioned folder, not beside the sources."""
    out = _cache_dirs(tmp_path, "numba.core.config, startrack")
    assert out[0] == out[1] and out[0].startswith(str(tmp_path / "startrack" / "numba"))
