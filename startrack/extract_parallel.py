"""Threads of the centroider: its compiled kernels run on row bands of the frame at once.

The kernels release the GIL (numba ``nogil``), so a few Python helper threads run them in
parallel without numba's threading layers (whose workqueue layer aborts when two threads
launch parallel kernels at once, as a caller's own thread pool would). A pass is cut into
more pieces than threads; the caller and the helpers take the next piece until none is
left, so a helper that wakes late (the machine busy) takes less, or nothing: the caller
never waits for a helper that has not started, only for pieces being worked on. Each piece
writes its own part of a result, or returns its own piece for a serial join in a fixed
order, so the result does not depend on how many threads there are, or on who did what.
The helpers are made on first use, and again in a forked child (whose copy of the
parent's threads is gone).
"""

from __future__ import annotations

import _thread
import os
import threading
from collections.abc import Callable, Sequence
from queue import SimpleQueue

MIN_BAND_PX = 65536  # px; a smaller piece of work is not worth a thread's wake-up
PIECES_PER_THREAD = 2  # a late helper then costs the caller at most a few pieces' time

_LOCK = threading.Lock()
_POOL: dict = {}  # "queue": the helpers' jobs, "pid": the process that made them, "size"


def thread_count(threads: int | None) -> int:
    """Threads to use: ``threads``; when None, numba's limit (``NUMBA_NUM_THREADS``, by
    default the cores this process may run on) or fewer when the machine is busy
    (``idle_cores``); at least 1."""
    if threads is not None:
        return max(1, int(threads))
    from numba import config  # numba: its thread limit, read only when none is given

    return max(1, min(int(config.NUMBA_NUM_THREADS), idle_cores()))


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
    """``[fn(*a) for a in args]`` on ``threads`` threads (the caller's and helpers');
    results in the order of ``args``."""
    n = len(args)
    if n == 1 or threads <= 1:
        return [fn(*a) for a in args]
    out: list = [None] * n
    job = (fn, args, out, [0, _thread.allocate_lock()])  # the next piece, and its lock
    queue = _helpers(threads - 1)
    states = []
    for _ in range(min(threads, n) - 1):
        done = _thread.allocate_lock()
        done.acquire()
        state = [False, done, None]  # claimed, released when finished, its error
        states.append(state)
        queue.put((job, state))
    _work(job, None)
    with job[3][1]:  # every piece is claimed: no helper that has not claimed yet will
        waits = [state for state in states if state[0]]
    for state in waits:  # those may be on a piece
        state[1].acquire()
    for state in states:
        if state[2] is not None:
            raise state[2]
    return out


def _work(job: tuple, state: list | None) -> None:
    """Take pieces of ``job`` until none is left; a helper's ``state`` notes that it did."""
    fn, args, out, claim = job
    while True:
        with claim[1]:
            i = claim[0]
            claim[0] = i + 1
            if state is not None:
                state[0] = True
        if i >= len(args):
            return
        out[i] = fn(*args[i])


def _helper(queue: SimpleQueue) -> None:
    while True:
        job, state = queue.get()
        try:
            _work(job, state)
        except BaseException as exc:  # noqa: BLE001 - handed to the caller, which raises it
            state[2] = exc
        finally:
            state[1].release()


def _helpers(workers: int) -> SimpleQueue:
    """The helpers' job queue, with at least ``workers`` helpers, made in this process."""
    with _LOCK:
        pid = os.getpid()
        if _POOL.get("pid") != pid:
            _POOL.update(queue=SimpleQueue(), pid=pid, size=0)
        while _POOL["size"] < workers:
            threading.Thread(target=_helper, args=(_POOL["queue"],), daemon=True,
                             name=f"startrack-extract-{_POOL['size']}").start()
            _POOL["size"] += 1
        return _POOL["queue"]
