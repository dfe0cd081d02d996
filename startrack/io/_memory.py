"""What the process holds in memory, and giving back what it need not hold.

A blind search sweeps deep pattern tables that are mapped from the disk cache: every
page it reads stays resident until the process exits, and a first use's table build
leaves its freed GB in the C heap. :func:`shed_memory` drops both (the mapped pages go
back to the page cache, the heap's free tail to the system), so that a command's peak is
what it uses at once, not everything it has touched.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools
import os

from startrack.io._npz import release_mapped_pages

_STATM = {"pid": None, "fd": None, "page": 0}  # this process's statm, opened once


def resident_bytes() -> int | None:
    """The process's resident memory (Linux's /proc/self/statm, held open: a search reads
    it after every window, and opening it costs ten times the read); None where
    unreadable."""
    try:
        if _STATM["pid"] != os.getpid():  # first use, or a forked child: its own file
            _STATM.update(pid=os.getpid(), fd=os.open(f"/proc/{os.getpid()}/statm", os.O_RDONLY),
                          page=os.sysconf("SC_PAGE_SIZE"))
        return int(os.pread(_STATM["fd"], 128, 0).split()[1]) * _STATM["page"]
    except (OSError, ValueError, IndexError):
        return None


@functools.cache
def _malloc_trim():
    """glibc's malloc_trim, or None (another C library, or none found)."""
    name = ctypes.util.find_library("c")
    try:
        return getattr(ctypes.CDLL(name), "malloc_trim", None) if name else None
    except OSError:
        return None


def trim_heap() -> None:
    """Give the C heap's free memory back to the system (glibc's malloc_trim; elsewhere
    nothing): numpy's large arrays freed after a build otherwise stay counted."""
    trim = _malloc_trim()
    if trim is not None:
        trim(0)


def shed_memory(above_bytes: int | None = None) -> bool:
    """Drop the mapped tables' pages and trim the heap: always with no ``above_bytes``,
    else only when the resident memory is above it (never where it cannot be read, as
    each shed costs the next search its pages back); whether it did."""
    if above_bytes is not None:
        resident = resident_bytes()
        if resident is None or resident <= above_bytes:
            return False
    release_mapped_pages()
    trim_heap()
    return True


__all__ = ["resident_bytes", "shed_memory", "trim_heap"]
