"""Run one piece of work per thread, for the compiled builds that split a table among
threads (their loops release the GIL)."""

from __future__ import annotations

import os
import threading
from collections.abc import Callable


def usable_cores() -> int:
    """The cores this process may run on (its CPU affinity), at least 1."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # no affinity on this system
        return os.cpu_count() or 1


def in_threads(work: Callable[[int], None], workers: int) -> None:
    """``work(t)`` for t in 0 .. workers - 1, each in its own thread but the last, which
    runs in the calling one; the first exception raised is raised here."""
    threads, errors = [], []

    def run(t):
        try:
            work(t)
        except BaseException as exc:  # handed to the caller below
            errors.append(exc)

    for t in range(workers - 1):
        thread = threading.Thread(target=run, args=(t,))
        thread.start()
        threads.append(thread)
    run(workers - 1)
    for thread in threads:
        thread.join()
    if errors:
        raise errors[0]
