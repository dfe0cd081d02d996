"""On-disk cache of database arrays, keyed by everything that determines them."""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from collections.abc import Callable
from pathlib import Path

import numpy as np

CACHE_VERSION = 1


def cache_dir() -> Path:
    """``$STARTRACK_CACHE_DIR``, else the user's cache directory."""
    env = os.environ.get("STARTRACK_CACHE_DIR")
    if env:
        return Path(env)
    from platformdirs import user_cache_dir

    return Path(user_cache_dir("startrack"))


def cache_key(kind: str, params: dict) -> str:
    blob = json.dumps({"kind": kind, "v": CACHE_VERSION, **params}, sort_keys=True, default=str)
    return f"{kind}-{hashlib.sha256(blob.encode()).hexdigest()[:20]}"


def cached_arrays(kind: str, params: dict,
                  build: Callable[[], dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
    """Load the arrays for (kind, params) from the cache, or build and store them.

    Writes go to a temporary file renamed into place, so an interrupted run never leaves
    a half-written entry; an unreadable entry is rebuilt.
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
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".tmp.npz")
        try:
            with os.fdopen(fd, "wb") as fh:
                np.savez(fh, **arrays)
            os.replace(tmp, path)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
    except OSError:
        pass  # a read-only cache only costs the rebuild next time
    return arrays
