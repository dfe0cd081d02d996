"""The one way startrack writes a file: whole or not at all, never onto an input, a link,
a pipe or a device, and never onto an existing file without ``--overwrite``.

The rule (docs/conventions.md, "Outputs"): every output is written to a temporary file
beside it and renamed into place (:func:`atomic_path`); a path that is a symlink, a
folder, a pipe or a device is refused, never replaced nor written through; a path that
is, or resolves to (same path, symlink, hard link), an input or an input's sidecar is
refused (:class:`Writer`); an existing file is refused unless ``--overwrite``. Every
error names the user's path, never the temporary file. Folders a command fills
(``simulate --out``, ``compare --out``) are :mod:`startrack.io._run_folder`'s.
"""

from __future__ import annotations

import contextlib
import errno
import os
import stat
import sys
import tempfile
import threading
from collections.abc import Iterable, Iterator
from pathlib import Path

from startrack.errors import InputError

_UMASK_LOCK = threading.Lock()
#: open run folders (startrack.io._run_folder): realpath -> the folder, told of each write
_FOLDERS: dict[str, object] = {}


class OutputClosed(Exception):
    """The reader of standard output went away (``| head -1``): stop without a message."""


class OutputError(InputError, OSError):
    """An output that cannot or must not be written; names the user's path (exit 2).
    An ``OSError`` too, so a caller that tolerates a failed write (the cache) still can."""


def current_umask() -> int:
    """The process umask (read without changing it where /proc allows)."""
    with contextlib.suppress(OSError, ValueError), open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    with _UMASK_LOCK:
        mask = os.umask(0o022)
        os.umask(mask)
    return mask


def _lstat(path: Path, what: str) -> os.stat_result | None:
    """lstat of ``path`` (the link itself, not its target); None when nothing is there."""
    try:
        return os.lstat(path)
    except FileNotFoundError:
        return None
    except NotADirectoryError:
        raise OutputError(f"{what} {path}: a parent folder is a file") from None
    except OSError as exc:
        raise OutputError(f"{what} {path}: cannot use ({exc.strerror or exc})") from None


def refuse_special(path: Path, st: os.stat_result | None, what: str) -> None:
    """Refuse an existing ``path`` that is not a regular file (it is never replaced)."""
    if st is None or stat.S_ISREG(st.st_mode):
        return
    if stat.S_ISLNK(st.st_mode):
        raise OutputError(f"{what} {path}: is a symlink; startrack never replaces a link, "
                          "give the file it points to")
    if stat.S_ISDIR(st.st_mode):
        raise OutputError(f"{what} {path}: is a folder")
    raise OutputError(f"{what} {path}: is not a regular file (a pipe or a device); "
                      "startrack writes regular files only")


def _check_parents(path: Path, what: str) -> None:
    """The nearest existing ancestor of a path that does not exist must be a folder."""
    parent = Path(os.path.abspath(path)).parent
    while not os.path.lexists(parent):
        parent = parent.parent
    if not parent.is_dir():
        raise OutputError(f"{what} {path}: a parent folder is a file ({parent})")


@contextlib.contextmanager
def atomic_path(path: str | Path, what: str = "output") -> Iterator[Path]:
    """Yield a temporary path beside ``path``; move it into place only on success.

    ``path`` must not be a symlink, folder, pipe or device (checked before and again just
    before the rename); any failure removes the temporary file and is an
    :class:`OutputError` naming ``path``. In an open run folder the file is listed in its
    manifest before it is created."""
    path = Path(path)
    refuse_special(path, _lstat(path, what), what)
    folder = _FOLDERS.get(os.path.realpath(path.parent))
    if folder is not None:
        folder.register(path.name)
    tmp = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.",
                                   suffix=path.suffix)
        try:
            os.fchmod(fd, 0o666 & ~current_umask())  # mkstemp makes 0600; follow the umask
        finally:
            os.close(fd)
        yield Path(tmp)
        refuse_special(path, _lstat(path, what), what)  # nothing swapped in meanwhile
        os.replace(tmp, path)
    except OutputError:
        raise
    except FileExistsError:
        raise OutputError(f"{what} {path}: a parent folder is a file") from None
    except NotADirectoryError:
        raise OutputError(f"{what} {path}: a parent folder is a file") from None
    except OSError as exc:
        reason = exc.strerror or _without(str(exc), tmp, path)
        raise OutputError(f"{what} {path}: cannot write ({reason})") from None
    except Exception as exc:  # a writer's own error (libpng's): never name the temporary
        if tmp is None or str(tmp) not in str(exc):
            raise
        raise OutputError(f"{what} {path}: cannot write "
                          f"({_without(str(exc), tmp, path)})") from None
    finally:
        if tmp is not None:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(tmp)


def _without(message: str, tmp, path: Path) -> str:
    """``message``'s first line with the temporary file's name replaced by ``path``."""
    lines = message.strip().splitlines() or [""]
    return lines[0].replace(str(tmp), str(path)) if tmp is not None else lines[0]


@contextlib.contextmanager
def atomic_text(path: str | Path, what: str = "output") -> Iterator:
    """A text file (LF line ends kept) that appears at ``path`` only when complete."""
    with atomic_path(path, what) as tmp, open(tmp, "w", newline="") as fh:
        yield GuardedFile(fh, f"{what} {path}")


def _write_error(where: str, exc: OSError) -> Exception:
    if exc.errno == errno.EPIPE and where == "standard output":
        return OutputClosed()
    return OutputError(f"{where}: cannot write ({exc.strerror or exc})")


class GuardedFile:
    """A text file whose write errors become one-line :class:`OutputError` s."""

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


class Writer:
    """One command's outputs: each checked against the command's inputs (and each
    input's sidecar) and the existing-file rule before any work, and written atomically.

    ``inputs``: every file the command reads (missing ones are ignored); ``overwrite``:
    an existing regular file may be replaced (else it is refused)."""

    def __init__(self, inputs: Iterable[str | Path] = (), overwrite: bool = False) -> None:
        self.overwrite = overwrite
        self.written: list[Path] = []
        self._claimed: dict[str, str] = {}  # real path -> the output (option) writing it
        self._inputs: dict[tuple[int, int], Path] = {}
        self._real: dict[str, Path] = {}
        for name in inputs:
            with contextlib.suppress(OSError):
                st = os.stat(name)
                self._inputs[(st.st_dev, st.st_ino)] = Path(name)
                self._real[os.path.realpath(name)] = Path(name)

    def input_at(self, path: str | Path) -> Path | None:
        """The input that ``path`` is or resolves to (path, symlink, hard link), if any."""
        hit = self._real.get(os.path.realpath(path))
        with contextlib.suppress(OSError):
            st = os.stat(path)
            hit = hit or self._inputs.get((st.st_dev, st.st_ino))
        return hit

    def check(self, path: str | Path, what: str, replace: bool | None = None) -> Path:
        """Refuse ``path`` as an output now, before any work (see the class doc);
        ``replace``: whether an existing file may be replaced (default: ``overwrite``)."""
        if str(path) == "-":  # the Unix name of standard output, never a file called "-"
            raise OutputError(f"{what} -: standard output is not a file here; give a file "
                              "name")
        path = Path(path)
        st = _lstat(path, what)
        name = self.input_at(path)
        if name is not None:
            raise OutputError(f"{what} {path}: is the input {name}; refusing to overwrite "
                              "an input")
        refuse_special(path, st, what)
        other = self._claimed.setdefault(os.path.realpath(path), what)
        if other != what:  # --output and --corr on one file: the second would replace the first
            raise OutputError(f"{what} {path}: is also {other}; give each output its own file")
        if st is None:
            _check_parents(path, what)
        elif not (self.overwrite if replace is None else replace) and path not in self.written:
            raise OutputError(f"{what} {path}: exists; give --overwrite to replace it")
        return path

    @contextlib.contextmanager
    def path(self, path: str | Path, what: str) -> Iterator[Path]:
        """A temporary path to write; it becomes ``path`` (checked again) on success."""
        path = self.check(path, what)
        with atomic_path(path, what) as tmp:
            yield tmp
        self.written.append(path)

    @contextlib.contextmanager
    def text(self, path: str | Path, what: str) -> Iterator[GuardedFile]:
        """:meth:`path` as an open text file (write errors name ``path``)."""
        with self.path(path, what) as tmp, open(tmp, "w", newline="") as raw:
            fh = GuardedFile(raw, f"{what} {path}")
            yield fh
            fh.flush()
            os.fsync(raw.fileno())
