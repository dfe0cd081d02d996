"""Files that appear only when complete: atomic output writes and the on-disk cache.

Every file startrack writes goes through here, so an interrupted run never leaves one
half-written: outputs (:func:`atomic_path`, :func:`atomic_text`) and cache entries
(:func:`cached_arrays` for arrays, :func:`cached_file` for a peer's own file format).
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np

CACHE_VERSION = 1


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; move it into place only on success."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=path.suffix)
    os.close(fd)
    try:
        yield Path(tmp)
        os.replace(tmp, path)
    finally:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)


@contextlib.contextmanager
def atomic_text(path: str | Path) -> Iterator:
    """Open a text file for writing that appears at ``path`` only when complete."""
    with atomic_path(path) as tmp, open(tmp, "w", newline="") as fh:
        yield fh


def cache_dir() -> Path:
    """``$STARTRACK_CACHE_DIR``, else the user's cache directory."""
    env = os.environ.get("STARTRACK_CACHE_DIR")
    if env:
        return Path(env)
    from platformdirs import user_cache_dir

    return Path(user_cache_dir("startrack"))


def cache_key(kind: str, params: dict) -> str:
    """A file stem unique to (kind, params) and the cache format version."""
    blob = json.dumps({"kind": kind, "v": CACHE_VERSION, **params}, sort_keys=True, default=str)
    return f"{kind}-{hashlib.sha256(blob.encode()).hexdigest()[:20]}"


def cached_arrays(kind: str, params: dict,
                  build: Callable[[], dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
    """Load the arrays for (kind, params) from the cache, or build and store them.

    An unreadable entry is rebuilt; a read-only cache only costs the rebuild next time.
    """
    path = cache_dir() / f"{cache_key(kind, params)}.npz"
    if path.exists():
        try:
            with np.load(path, allow_pickle=False) as data:
                arrays = {name: data[name] for name in data.files}
            if arrays:
                return arrays
        except Exception:  # any damage (truncation, bad zip, bad CRC) means a rebuild
            pass
    arrays = build()
    with contextlib.suppress(OSError), atomic_path(path) as tmp, open(tmp, "wb") as fh:
        np.savez(fh, **arrays)
    return arrays


def cached_file(kind: str, params: dict, suffix: str, build: Callable[[Path], None]) -> Path:
    """The cache path for (kind, params); ``build(tmp_path)`` writes it when missing."""
    path = cache_dir() / f"{cache_key(kind, params)}{suffix}"
    if not path.exists():
        with atomic_path(path) as tmp:
            build(tmp)
    return path
