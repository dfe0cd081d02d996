"""Waiting on a child process in tests: on events, never on a fixed sleep; and running a
fresh interpreter to its end.

A test waits for what a child does (a file it writes, a worker it starts) by polling
:func:`wait_for`. The limits here are safety nets against a hung child, not time limits:
generous enough for a first run that compiles kernels on a 2-core machine at load 6.
"""

from __future__ import annotations

import subprocess
import sys
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


def run_python(code: str, *args: str, env: dict[str, str] | None = None) -> str:
    """The standard output of ``python -c code *args`` in a fresh interpreter (what a
    module loads shows only in a process that has imported nothing yet); fails the test,
    with the child's standard error, if the child does not exit 0."""
    proc = subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True,
                          env=env, timeout=CHILD_TIMEOUT_S)
    assert proc.returncode == 0, proc.stderr
    return proc.stdout
