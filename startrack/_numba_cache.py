"""Where numba keeps startrack's compiled kernels: a folder per version of the sources.

numba invalidates a cached kernel when the file that defines it changes, but not when a
kernel it calls, defined in another file, does: after an update that touched only a
callee, the caller's cached machine code would still run the old callee. Keying the
cache folder on the contents of every file that defines kernels makes any change to one
start a fresh cache (an installed release compiles once per version, as before); the folders
of the last few versions are kept, and no folder used within the last day is removed, so
checkouts side by side (or a long run of an older install) never lose their kernels while
they run.
An explicit ``NUMBA_CACHE_DIR`` is left alone; when numba was imported first (and so has
read its settings already), it is told the folder too.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import sys
import time
from pathlib import Path

from platformdirs import user_cache_dir

PREFIX = "kernels-"
KEEP = 4  # source versions kept (checkouts side by side each have their own)
# A folder used more recently than this is never pruned: a process started before may still
# be compiling into it (numba fails when its cache folder disappears under it).
MIN_AGE_S = 86400.0


def configure() -> None:
    """Point ``NUMBA_CACHE_DIR`` at this source version's folder (before numba loads)."""
    if "NUMBA_CACHE_DIR" in os.environ:
        return
    try:
        root = Path(user_cache_dir("startrack")) / "numba"
        folder = root / (PREFIX + _source_stamp())
        if folder.is_dir():
            os.utime(folder)  # last used: kept by _prune
        else:
            folder.mkdir(parents=True, exist_ok=True)
            _prune(root)
    except OSError:  # no writable cache: numba's own default applies
        return
    os.environ["NUMBA_CACHE_DIR"] = str(folder)
    config = sys.modules.get("numba.core.config")
    if config is not None:
        # numba was imported first and read its settings then; each kernel reads the
        # folder when its module defines it (after this), so telling numba now is enough.
        config.CACHE_DIR = str(folder)


def _source_stamp(package: Path | None = None) -> str:
    """A digest of the package's compiled-kernel sources (the Python files that use numba's
    ``njit``): their paths and contents. Other files do not change compiled code."""
    package = package or Path(__file__).resolve().parent
    digest = hashlib.sha256()
    stack = [package]
    while stack:
        folder = stack.pop()
        for entry in sorted(os.scandir(folder), key=lambda e: e.name):
            if entry.is_dir() and entry.name != "__pycache__":
                stack.append(Path(entry.path))
            elif entry.name.endswith(".py"):
                with open(entry.path, "rb") as f:
                    text = f.read()
                if b"njit" in text:
                    digest.update(entry.path.encode() + b"\0" + text + b"\0")
    return digest.hexdigest()[:16]


def _prune(root: Path) -> None:
    """Keep the :data:`KEEP` most recently used source versions' folders, and any used
    within :data:`MIN_AGE_S`."""
    folders = sorted(root.glob(PREFIX + "*"), key=lambda p: p.stat().st_mtime, reverse=True)
    cutoff = time.time() - MIN_AGE_S
    for old in folders[KEEP:]:
        if old.stat().st_mtime < cutoff:
            shutil.rmtree(old, ignore_errors=True)
