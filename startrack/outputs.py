"""Opening an output safely: a file appears whole or not at all, a device, pipe or
symlink is written through and never replaced, and an input is never overwritten.

The rule (shared/interfaces.md): an output path that exists and is not a regular file is
written through (a device, a pipe) or, for a symlink, its target is written (atomically
when the target is a regular file); the link itself stays. A write error (a full disk,
``/dev/full``, a closed pipe) is an :class:`InputError` naming the output; a closed
pipe on standard output is :class:`OutputClosed`, which the command line ends quietly.
"""

from __future__ import annotations

import contextlib
import errno
import os
import stat
import sys
from collections.abc import Iterable, Iterator
from pathlib import Path

from startrack.cache import atomic_path
from startrack.errors import InputError


class OutputClosed(Exception):
    """The reader of standard output went away (``| head -1``): stop without a message."""


def _write_error(where: str, exc: OSError) -> Exception:
    if exc.errno == errno.EPIPE and where == "standard output":
        return OutputClosed()
    return InputError(f"{where}: cannot write ({exc.strerror or exc})")


class GuardedFile:
    """A text file whose write errors become one-line :class:`InputError` s."""

    def __init__(self, fh, where: str) -> None:
        self._fh = fh
        self.where = where

    def write(self, text: str) -> int:
        try:
            return self._fh.write(text)
        except OSError as exc:
            raise _write_error(self.where, exc) from None

    def writelines(self, lines: Iterable[str]) -> None:
        for line in lines:
            self.write(line)

    def flush(self) -> None:
        try:
            self._fh.flush()
        except OSError as exc:
            raise _write_error(self.where, exc) from None

    def __getattr__(self, name):
        return getattr(self._fh, name)


def guarded_stdout() -> GuardedFile:
    """Standard output, its write errors made one line (a closed pipe: quiet)."""
    return GuardedFile(sys.stdout, "standard output")


def refuse_inputs(path: str | Path, inputs: Iterable[str | Path], what: str) -> None:
    """An InputError when ``path`` is (the same file as) one of ``inputs``."""
    path = Path(path)
    if not path.exists():
        return
    for name in inputs:
        with contextlib.suppress(OSError):
            if os.path.samefile(path, name):
                raise InputError(f"{what} {path}: is the input {name}; refusing to "
                                 "overwrite an input")


def _existing(path: Path, what: str) -> os.stat_result | None:
    """stat of what ``path`` points at, None when nothing is there; bad parents refused."""
    try:
        return os.stat(path)
    except FileNotFoundError:
        return None
    except NotADirectoryError:
        raise InputError(f"{what} {path}: a parent folder is a file") from None
    except OSError as exc:
        raise InputError(f"{what} {path}: cannot use ({exc.strerror or exc})") from None


def check_output(path: str | Path, inputs: Iterable[str | Path] = (),
                 what: str = "--output") -> None:
    """Refuse, before any work, an output that could not be written or is an input."""
    path = Path(path)
    st = _existing(path, what)
    if st is not None and stat.S_ISDIR(st.st_mode):
        raise InputError(f"{what} {path}: is a folder")
    refuse_inputs(path, inputs, what)
    if st is None:
        _check_parents(path, what)


def _check_parents(path: Path, what: str) -> None:
    """The nearest existing ancestor of a path that does not exist must be a folder."""
    parent = Path(os.path.realpath(path)).parent
    while not parent.exists():
        parent = parent.parent
    if not parent.is_dir():
        raise InputError(f"{what} {path}: a parent folder is a file ({parent})")


@contextlib.contextmanager
def open_output(path: str | Path, inputs: Iterable[str | Path] = (),
                what: str = "--output") -> Iterator[GuardedFile]:
    """A text file to write ``path`` through, following the rule above."""
    path = Path(path)
    inputs = list(inputs)
    check_output(path, inputs, what)
    where = f"{what} {path}"
    st = _existing(path, what)
    try:
        if st is not None and not stat.S_ISREG(st.st_mode):
            with open(path, "w", newline="") as raw:  # device or pipe: write through
                fh = GuardedFile(raw, where)
                yield fh
                fh.flush()
            return
        target = Path(os.path.realpath(path))  # a symlink: write its target, keep the link
        with atomic_path(target) as tmp, open(tmp, "w", newline="") as raw:
            fh = GuardedFile(raw, where)
            yield fh
            fh.flush()
            os.fsync(raw.fileno())
    except OSError as exc:
        raise _write_error(where, exc) from None


def check_out_folder(out: str | Path, overwrite: bool, what: str = "--out") -> None:
    """Refuse an output folder that is a file, or that is not empty without ``overwrite``
    (files from an earlier run would be mistaken for this run's)."""
    out = Path(out)
    st = _existing(out, what)
    if st is None:
        _check_parents(out, what)
        return
    if not stat.S_ISDIR(st.st_mode):
        raise InputError(f"{what} {out}: exists and is not a folder")
    if not overwrite and any(os.scandir(out)):
        raise InputError(f"{what} {out}: folder is not empty; give --overwrite to replace "
                         "an earlier run's files, or choose another folder")


def remove_own(out: str | Path, patterns: Iterable[str]) -> int:
    """Remove the files matching ``patterns`` (a command's own outputs) from ``out``."""
    count = 0
    for pattern in patterns:
        for path in Path(out).glob(pattern):
            if path.is_file() or path.is_symlink():
                path.unlink()
                count += 1
    return count
