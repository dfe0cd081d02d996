"""Threads of the centroider: its compiled kernels run on row bands of the frame at once.

The kernels release the GIL (numba ``nogil``), so a small pool of Python threads runs
them in parallel without numba's threading layers (whose workqueue layer aborts when two
threads launch parallel kernels at once, as a caller's own thread pool would). Each band
writes its own part of a result, or returns its own piece for a serial join in a fixed
order, so the result does not depend on how many threads there are, or on which ends
first. The pool is made on first use, and again in a forked child (whose copy of the
parent's threads is gone).
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor

MIN_BAND_PX = 65536  # px; a smaller piece of work is not worth a thread's wake-up

_LOCK = threading.Lock()
_POOL: dict = {}  # "pool": the executor, "pid": the process that made it, "size"


def thread_count(threads: int | None) -> int:
    """Threads to use: ``threads``, or numba's limit (``NUMBA_NUM_THREADS``, by default
    the cores this process may run on) when None; at least 1."""
    if threads is None:
        from numba import config

        threads = config.NUMBA_NUM_THREADS
    return max(1, int(threads))


def bands(n: int, parts: int) -> list[tuple[int, int]]:
    """``range(n)`` cut into ``parts`` contiguous (start, stop) pieces of near-equal size
    (fewer when n is smaller), in order."""
    parts = max(1, min(parts, n))
    edges = [n * i // parts for i in range(parts + 1)]
    return list(zip(edges[:-1], edges[1:], strict=True))


def parts_for(threads: int, pixels: int) -> int:
    """How many bands to cut a pass over ``pixels`` into with ``threads`` threads."""
    return max(1, min(threads, pixels // MIN_BAND_PX))


def run(fn: Callable, args: Sequence[tuple]) -> list:
    """``[fn(*a) for a in args]``, the calls after the first on the pool's threads while
    the caller makes the first; results in the order of ``args``."""
    if len(args) == 1:
        return [fn(*args[0])]
    pool = _pool(len(args) - 1)
    futures = [pool.submit(fn, *a) for a in args[1:]]
    first = fn(*args[0])
    return [first] + [f.result() for f in futures]


def _pool(workers: int) -> ThreadPoolExecutor:
    """The shared pool, with at least ``workers`` threads, made in this process."""
    with _LOCK:
        pid = os.getpid()
        if _POOL.get("pid") != pid or _POOL["size"] < workers:
            old = _POOL.get("pool") if _POOL.get("pid") == pid else None
            _POOL.update(pool=ThreadPoolExecutor(workers, "startrack-extract"), pid=pid,
                         size=workers)
            if old is not None:
                old.shutdown(wait=False)
        return _POOL["pool"]
