"""Threads of the centroider: its compiled passes run on row bands of the frame at once.

The compiled kernels release the GIL, so a standard ``ThreadPoolExecutor`` runs them in
parallel. A pass is cut into more pieces than threads; the caller and the pool's threads
take the next piece until none is left, and the caller then withdraws the helpers' turns
that have not started, so a helper that wakes late (the machine busy) costs nothing: the
caller waits only for pieces being worked on. Each piece writes its own part of a result,
or returns its own piece for a serial join in a fixed order, so the result does not
depend on how many threads there are, or on who did what. The pool is made on first use,
and again in a forked child (whose copy of the parent's threads is gone).
"""

from __future__ import annotations

import itertools
import os
import threading
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor

from startrack._core._threads import usable_cores

MIN_BAND_PX = 65536  # px; a smaller piece of work is not worth a thread's wake-up
PIECES_PER_THREAD = 2  # a late helper then costs the caller at most a few pieces' time

_LOCK = threading.Lock()
_POOL: dict = {}  # "pool": the executor, "pid": the process that made it, "size"


def thread_count(threads: int | None) -> int:
    """Threads to use: ``threads``; when None, the cores this process may run on, or
    fewer when the machine is busy (``idle_cores``); at least 1."""
    if threads is not None:
        return max(1, int(threads))
    return max(1, min(usable_cores(), idle_cores()))


def idle_cores() -> int:
    """Cores left to this process by the others, from the 1-minute load average (which
    counts this process's own running thread too).

    A helper thread that has to wait for a busy core costs the caller more, in hand-offs
    and in losing its own core to the others, than it saves: on a loaded machine one
    thread is faster.
    """
    try:
        load = os.getloadavg()[0]
    except (AttributeError, OSError):  # no load average on this system
        return os.cpu_count() or 1
    return int((os.cpu_count() or 1) + 1.5 - load)


def bands(n: int, parts: int) -> list[tuple[int, int]]:
    """``range(n)`` cut into ``parts`` contiguous (start, stop) pieces of near-equal size
    (fewer when n is smaller), in order."""
    parts = max(1, min(parts, n))
    edges = [n * i // parts for i in range(parts + 1)]
    return list(zip(edges[:-1], edges[1:], strict=True))


def parts_for(threads: int, pixels: int) -> int:
    """How many pieces to cut a pass over ``pixels`` into with ``threads`` threads: one on
    one thread, else up to ``PIECES_PER_THREAD`` a thread of at least ``MIN_BAND_PX``."""
    if threads <= 1:
        return 1
    return max(1, min(PIECES_PER_THREAD * threads, pixels // MIN_BAND_PX))


def run(fn: Callable, args: Sequence[tuple], threads: int) -> list:
    """``[fn(*a) for a in args]`` on ``threads`` threads (the caller's and the pool's);
    results in the order of ``args``; a piece's error is raised in the caller."""
    n = len(args)
    if n == 1 or threads <= 1:
        return [fn(*a) for a in args]
    out: list = [None] * n
    claims = itertools.count()  # the next piece; its next() is atomic

    def work() -> None:
        for i in claims:
            if i >= n:
                return
            out[i] = fn(*args[i])

    pool = _pool(threads - 1)
    helpers = [pool.submit(work) for _ in range(min(threads, n) - 1)]
    try:
        work()
    finally:
        started = [h for h in helpers if not h.cancel()]  # those may be on a piece
        for h in started:
            h.exception()  # waits
    for h in started:
        if h.exception() is not None:
            raise h.exception()
    return out


def _pool(workers: int) -> ThreadPoolExecutor:
    """The helpers' executor, with at least ``workers`` threads, made in this process."""
    with _LOCK:
        pid = os.getpid()
        if _POOL.get("pid") != pid or _POOL["size"] < workers:
            if _POOL.get("pid") == pid:
                _POOL["pool"].shutdown(wait=False)  # its running pieces still finish
            _POOL.update(pool=ThreadPoolExecutor(workers, "startrack-extract"), pid=pid,
                         size=workers)
        return _POOL["pool"]
