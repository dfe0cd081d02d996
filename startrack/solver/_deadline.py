"""One wall-clock limit per input (``--timeout-ms``), shared by every stage that works on it.

A :class:`Deadline` is made once when an input's identification starts and handed to each
stage in turn (the configured method, the FOV refit, the focal-length search of
:mod:`startrack.solver._fov_search`), so their times add up against the one limit. The stages check
it
between units of work (hypotheses, search windows); a stage that finds it passed stops
and its input is not solved, with reason ``"timeout"``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

from startrack.io import build_seconds


def clock() -> float:
    """Seconds on the clock every deadline is read from (a test may replace it): wall
    seconds less those this process spent building cache entries, so that the first use
    of a deep sky (its pattern tables built once, announced on stderr) does not spend the
    search's time limit and end in a timeout that a second run would not."""
    return time.perf_counter() - build_seconds()


@dataclass(frozen=True)
class Deadline:
    """A point in :func:`clock` seconds past which work stops; None: no limit."""

    at: float | None = None

    @classmethod
    def after_ms(cls, timeout_ms: float | None, start: float | None = None) -> Deadline:
        """The deadline ``timeout_ms`` after ``start`` (default: now); None: no limit."""
        if timeout_ms is None:
            return cls(None)
        start = clock() if start is None else start
        return cls(start + float(timeout_ms) / 1000.0)

    def passed(self) -> bool:
        """True once the limit is reached (never without a limit)."""
        return self.at is not None and clock() >= self.at

    def earliest(self, other: Deadline | None) -> Deadline:
        """The sooner of this deadline and ``other``."""
        if other is None or other.at is None:
            return self
        if self.at is None:
            return other
        return Deadline(min(self.at, other.at))


#: no wall-clock limit: only the work budgets bound the search
NO_DEADLINE = Deadline(None)
