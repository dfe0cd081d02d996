"""Waiting on a child process in tests: on events, never on a fixed sleep.

A test waits for what a child does (a file it writes, a worker it starts) by polling
:func:`wait_for`. The limits here are safety nets against a hung child, not time limits:
generous enough for a first run that compiles kernels on a 2-core machine at load 6.
"""

from __future__ import annotations

import time
from collections.abc import Callable

#: the overall limit of one child process (``subprocess.run(..., timeout=)``, ``wait()``)
CHILD_TIMEOUT_S = 900.0


def wait_for(predicate: Callable[[], bool], timeout: float = CHILD_TIMEOUT_S,
             poll_s: float = 0.1) -> None:
    """Return once ``predicate()`` is true; fail the test if it is not by ``timeout``."""
    end = time.monotonic() + timeout
    while not predicate():
        assert time.monotonic() < end, f"timed out after {timeout:.0f} s waiting"
        time.sleep(poll_s)
