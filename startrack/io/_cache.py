"""Files that appear only when complete: atomic output writes and the on-disk cache.

Cache entries (:func:`cached_arrays` for arrays, :func:`cached_file` for a peer's own
file format) are written as every output is (:func:`startrack.io._writer.atomic_path`), so an
interrupted run never leaves one half-written.

Cache entries carry an XXH3-128 hash of their arrays (xxhash), checked on every load, so an
entry whose contents were damaged (not just torn) is rebuilt rather than trusted. Each entry
also stores its key (kind, cache version, parameters: for a parsed catalog its source file's
path, size and modification time and the parser's version), covered by the hash and compared
on load, so a valid entry of another catalog copied over this one is rebuilt, not trusted. XXH3 is
not a cryptographic hash: it detects damage, not deliberate tampering; it reads ~10x
faster than SHA-256, which had become the largest part of a warm start. The cache is
bounded: after each write the least recently used entries are evicted until the total is
at most ``$STARTRACK_CACHE_MAX_MB`` (default :data:`DEFAULT_CACHE_MAX_MB`).
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import re
import sys
import threading
import time
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np
from platformdirs import user_cache_dir

from startrack.errors import StartrackWarning
from startrack.input_checks import CACHE_MAX_MB, env_number
from startrack.io._memory import shed_memory, trim_heap
from startrack.io._npz import CHECKSUM_KEY, ENTRY_KEY, arrays_checksum
from startrack.io._npz import read_npz as _read_npz
from startrack.io._npz import write_npz as _write_npz
from startrack.io._writer import atomic_path

CACHE_VERSION = 4  # 2: a checksum; 3: XXH3-128 instead of SHA-256; 4: the key inside
# room for a blind search's pattern tables, Gaia's and Tycho-2's narrow levels (~1.4 GB,
# ~0.1 to 0.4 GB each, mapped), beside a dozen cameras' pair tables (~150 MB each): the
# real frames of 12 cameras filled 4 GB, and evicting a narrow level costs a 30 s rebuild
DEFAULT_CACHE_MAX_MB = 8192
#: an entry this large (a deep catalog, its pattern tables) is mapped, not read: a process
#: touches only the pages its lookups need, and loading costs milliseconds. Its hash is
#: checked when it is written; on load, the key, every member's size and the zip
#: directory are (a write is atomic, so a torn entry cannot appear); a smaller entry's
#: hash is checked on every load.
MAP_MIN_BYTES = 16 * 1024 * 1024
#: a build still running after this many seconds says so on stderr (when builds are
#: announced: :func:`announce_builds`, which the command line turns on unless -q)
BUILD_NOTICE_S = 3.0
_announce = {"on": False}


def announce_builds(on: bool) -> None:
    """Whether a slow build of a cache entry prints one line on stderr saying what it
    builds (a deep catalog's tables take minutes, once)."""
    _announce["on"] = bool(on)


_build_seconds = [0.0]  # this process's seconds spent building cache entries
# builds under way and when the first of them started: a build within a build (a level
# that needs its catalog's table), or one in another thread, is not counted twice
_building = {"depth": 0, "since": 0.0}
_building_lock = threading.Lock()


def build_seconds() -> float:
    """Seconds this process has spent building cache entries: a one-time cost that the
    solver's time limit leaves out (startrack.solver._deadline.clock)."""
    return _build_seconds[0]


def _built(kind: str, build: Callable[[], dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
    """``build()``, timed into :func:`build_seconds`, with the mapped entries' pages
    dropped from the process first and the heap trimmed after
    (:mod:`startrack.io._memory`: a deep level's build holds a GB, the tables searched so
    far need not sit under it, nor its freed arrays under the search that follows)."""
    shed_memory()
    with _building_lock:
        if _building["depth"] == 0:
            _building["since"] = time.perf_counter()
        _building["depth"] += 1
    try:
        return _announced(kind, build)
    finally:
        with _building_lock:
            _building["depth"] -= 1
            if _building["depth"] == 0:
                _build_seconds[0] += time.perf_counter() - _building["since"]
        trim_heap()


def _announced(kind: str, build: Callable[[], dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
    """``build()``, announced on stderr when it runs past :data:`BUILD_NOTICE_S`."""
    if not _announce["on"]:
        return build()

    def say() -> None:
        print(f"startrack: building the {kind} table once (it is kept in {cache_dir()} "
              "for later runs)...", file=sys.stderr, flush=True)

    timer = threading.Timer(BUILD_NOTICE_S, say)
    timer.daemon = True
    timer.start()
    try:
        return build()
    finally:
        timer.cancel()
# What the cache writes: kind-<20 hex>.suffix; anything else in the folder is left alone.
ENTRY_NAME = re.compile(r"^[a-z0-9_]+-[0-9a-f]{20}(\.[A-Za-z0-9]+)+$")
TEMP_NAME = re.compile(r"^\.[a-z0-9_]+-[0-9a-f]{20}\.")


def cache_dir() -> Path:
    """``$STARTRACK_CACHE_DIR``, else the user's cache directory."""
    env = os.environ.get("STARTRACK_CACHE_DIR")
    if env:
        return Path(env)
    return Path(user_cache_dir("startrack"))


def cache_max_bytes() -> int:
    """The cache size cap: ``$STARTRACK_CACHE_MAX_MB`` megabytes (default
    :data:`DEFAULT_CACHE_MAX_MB`)."""
    mb = env_number("STARTRACK_CACHE_MAX_MB", DEFAULT_CACHE_MAX_MB, CACHE_MAX_MB)
    return int(mb * 1024 * 1024)


def key_text(kind: str, params: dict) -> str:
    """The canonical text of an entry's key: (kind, cache format version, params)."""
    return json.dumps({"kind": kind, "v": CACHE_VERSION, **params}, sort_keys=True, default=str)


def cache_key(kind: str, params: dict) -> str:
    """A file stem unique to (kind, params) and the cache format version."""
    return f"{kind}-{hashlib.sha256(key_text(kind, params).encode()).hexdigest()[:20]}"


def _load_checked(path: Path, key: str) -> dict[str, np.ndarray] | None:
    """The arrays of a cache entry, or None when it is damaged, altered or another entry
    (its stored ``key`` differs: what the file name says is not what the entry holds)."""
    try:
        mapped = path.stat().st_size >= MAP_MIN_BYTES
        arrays = _read_npz(path, mapped)
    except Exception:  # any damage (truncation, bad zip, bad header) means a rebuild
        return None
    stored = arrays.pop(CHECKSUM_KEY, None)
    if not arrays or stored is None or (not mapped and str(stored) != arrays_checksum(arrays)):
        return None
    stored_key = arrays.pop(ENTRY_KEY, None)
    if stored_key is None or stored_key.shape != () or str(stored_key) != key or not arrays:
        return None
    return arrays


def _touch(path: Path) -> None:
    """Mark an entry as just used (the eviction order); atime is unreliable on most mounts."""
    with contextlib.suppress(OSError):
        os.utime(path)


def cached_arrays(kind: str, params: dict,
                  build: Callable[[], dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
    """Load the arrays for (kind, params) from the cache, or build and store them.

    A damaged or altered entry (checksum mismatch), or one whose stored key is not
    (kind, params), is rebuilt; a read-only cache only costs the rebuild next time.
    """
    path = cache_dir() / f"{cache_key(kind, params)}.npz"
    key = key_text(kind, params)
    if path.exists():
        arrays = _load_checked(path, key)
        if arrays is not None:
            _touch(path)
            return arrays
    arrays = _built(kind, build)
    try:
        with atomic_path(path, "cache entry") as tmp:
            _write_npz(tmp, {**arrays, ENTRY_KEY: np.array(key)})
    except OSError as exc:
        _warn_unwritable(exc)
        return arrays
    evict(keep=path)
    # a large entry just written is used through its map: the built arrays are let go,
    # so the rest of the run holds only the pages it reads
    if sum(np.asarray(a).nbytes for a in arrays.values()) >= MAP_MIN_BYTES:
        mapped = _load_checked(path, key)
        if mapped is not None:
            return mapped
    return arrays


_warned_unwritable: list[str] = []  # the cache folders already warned about, this process


def _warn_unwritable(exc: OSError) -> None:
    """Say once that the cache cannot be written: every run then rebuilds its databases
    (a minute and more), which the user would otherwise see only as slowness."""
    folder = str(cache_dir())
    if folder in _warned_unwritable:
        return
    _warned_unwritable.append(folder)
    reason = exc.strerror or str(exc)
    warnings.warn(f"cache folder {folder} cannot be written ({reason}): databases are "
                  "rebuilt on every run (set STARTRACK_CACHE_DIR)", StartrackWarning,
                  stacklevel=2)


def cached_file(kind: str, params: dict, suffix: str, build: Callable[[Path], None]) -> Path:
    """The cache path for (kind, params); ``build(tmp_path)`` writes it when missing."""
    path = cache_dir() / f"{cache_key(kind, params)}{suffix}"
    if path.exists():
        _touch(path)
        return path
    with atomic_path(path) as tmp:
        build(tmp)
    evict(keep=path)
    return path


def cache_entries(folder: Path | None = None) -> list[tuple[Path, int, float]]:
    """(path, bytes, last use) of every cache entry, least recently used first."""
    folder = cache_dir() if folder is None else folder
    found = []
    with contextlib.suppress(OSError):
        for entry in os.scandir(folder):
            if entry.is_file(follow_symlinks=False) and ENTRY_NAME.match(entry.name):
                with contextlib.suppress(OSError):
                    st = entry.stat(follow_symlinks=False)
                    found.append((Path(entry.path), st.st_size, st.st_mtime))
    return sorted(found, key=lambda e: e[2])


def evict(keep: Path | None = None, max_bytes: int | None = None) -> list[Path]:
    """Remove least recently used entries until the cache fits its cap; ``keep`` stays."""
    cap = cache_max_bytes() if max_bytes is None else max_bytes
    entries = cache_entries(None if keep is None else keep.parent)
    total = sum(size for _, size, _ in entries)
    removed = []
    for path, size, _ in entries:
        if total <= cap:
            break
        if keep is not None and path == keep:
            continue
        with contextlib.suppress(OSError):
            path.unlink()
            removed.append(path)
            total -= size
    return removed


def clear_cache() -> tuple[int, int]:
    """Remove every cache entry (and leftover temporary files); (entries, bytes) freed."""
    entries = cache_entries()
    freed = 0
    for path, size, _ in entries:
        with contextlib.suppress(OSError):
            path.unlink()
            freed += size
    # Temporary files of writes that were killed; an hour old, so no write in progress.
    with contextlib.suppress(OSError):
        for entry in os.scandir(cache_dir()):
            if TEMP_NAME.match(entry.name):
                with contextlib.suppress(OSError):
                    if time.time() - entry.stat(follow_symlinks=False).st_mtime > 3600:
                        os.unlink(entry.path)
    return len(entries), freed


def cached_parse(kind: str, source: Path, version: int,
                 parse: Callable[[Path], dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
    """``parse(source)`` cached under the file's path, size and modification time (and the
    parser's ``version``), so an updated catalog file is parsed again."""
    stat = source.stat()
    key = {"path": str(source.resolve()), "size": stat.st_size, "mtime_ns": stat.st_mtime_ns,
           "format": version}
    return cached_arrays(kind, key, lambda: parse(source))
