"""Progress on stderr, one rule for every command: a bar on a terminal; a line every
:data:`LINE_SECONDS` seconds when stderr is a file or a pipe (a log, CI, ``nohup``),
so a long run shows it is alive; nothing with ``-q``."""

from __future__ import annotations

import sys
import time

from tqdm import tqdm

#: seconds between two progress lines when stderr is not a terminal
LINE_SECONDS = 10.0


class LineProgress:
    """A progress counter printing ``desc: done/total unit (pct), elapsed, left`` lines
    every ``every`` seconds, and a last one at the end of a run that printed any (a run
    shorter than ``every`` prints nothing); tqdm's update/close subset."""

    def __init__(self, total: int, initial: int = 0, *, desc: str = "", unit: str = "it",
                 every: float = LINE_SECONDS, stream=None, clock=time.monotonic) -> None:
        self.total, self.n, self.desc, self.unit = total, initial, desc, unit
        self.every, self.clock = every, clock
        self.stream = stream if stream is not None else sys.stderr
        self.start = self.last = clock()
        self.first = initial
        self.printed_at: int | None = None  # the count of the last line printed
        self.closed = False

    def update(self, n: int = 1) -> None:
        self.n += n
        if self.clock() - self.last >= self.every:
            self._line()

    def _line(self) -> None:
        now = self.clock()
        self.last, self.printed_at = now, self.n
        elapsed = now - self.start
        done = self.n - self.first
        left = (f", ~{_duration(elapsed / done * (self.total - self.n))} left"
                if done > 0 and self.total > self.n else "")
        pct = f" ({100.0 * self.n / self.total:.0f}%)" if self.total else ""
        print(f"{self.desc}: {self.n}/{self.total} {self.unit}{pct}, "
              f"{_duration(elapsed)} elapsed{left}", file=self.stream, flush=True)

    def close(self) -> None:
        if not self.closed and self.printed_at is not None and self.n != self.printed_at:
            self._line()
        self.closed = True

    def __enter__(self) -> LineProgress:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _duration(seconds: float) -> str:
    seconds = max(0.0, seconds)
    if seconds < 90:
        return f"{seconds:.0f} s"
    if seconds < 5400:
        return f"{seconds / 60:.1f} min"
    return f"{seconds / 3600:.1f} h"


def progress(total: int, *, initial: int = 0, desc: str, unit: str, quiet: bool = False,
             leave: bool = True):
    """A progress counter for ``total`` steps (``update(n)``, ``close()``): a tqdm bar
    when stderr is a terminal, :class:`LineProgress` when it is not, a silent one with
    ``quiet``."""
    if quiet or sys.stderr.isatty():
        return tqdm(total=total, initial=initial, file=sys.stderr, unit=unit, desc=desc,
                    disable=quiet, dynamic_ncols=True, leave=leave)
    return LineProgress(total, initial, desc=desc, unit=unit)


def iterate(items, *, desc: str, unit: str, quiet: bool = False):
    """Yield ``items`` while counting them with :func:`progress`; a sized iterable (a
    ``range`` of 100 million frames) is never listed."""
    if not hasattr(items, "__len__"):
        items = list(items)
    counter = progress(len(items), desc=desc, unit=unit, quiet=quiet)
    try:
        for item in items:
            yield item
            counter.update(1)
    finally:
        counter.close()
