"""A folder a command fills (``simulate --out``, ``compare --out`` in every mode): one lock,
one manifest of the files startrack wrote there, and nothing else touched.

While a run holds the folder (:class:`RunFolder` as a context manager) it holds
``.lock`` (``flock``): a second run on the same folder, whatever its command or mode, is
refused with one line. ``.startrack-files`` lists every file a startrack run wrote in the
folder; each write (:func:`startrack.io._writer.atomic_path`) is listed before it starts. A
file that is not listed (a user's ``notes.txt``, ``plot_x.png`` or ``.env.defaults``) makes
the folder refused without ``--overwrite``, and is never deleted nor replaced: clean-up
removes exactly the listed files of an earlier run, never files matched by a pattern, and a
run refuses to write a name it would take from the user (even with ``--overwrite``).

The manifest names the command that wrote the files: a folder holding another command's
run (``compare --out`` onto a ``simulate`` folder) is refused whatever ``--overwrite``
says, so no run deletes another kind of run's files. The temporaries a killed run left
(``.truth.csv.<random>.csv``) are removed by the next run that holds the folder.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
from collections.abc import Iterable
from pathlib import Path

from startrack.io._writer import _FOLDERS, OutputError, Writer, _check_parents, _lstat, atomic_path

LOCK_FILE = ".lock"
MANIFEST_FILE = ".startrack-files"
MANIFEST_FORMAT = 1
# mkstemp names of atomic_path: .<file>.<8 random chars><the file's suffix>
_TEMP_TAIL = re.compile(r"[A-Za-z0-9_]{8}(\.[A-Za-z0-9]+)?")
#: at most this many unlisted names are quoted in the refusal
_QUOTED = 3


class RunFolder:
    """The folder ``out`` of one run of ``command`` (see the module doc).

    ``inputs``: the files the run reads (never written, whatever the folder holds);
    ``overwrite``: write although the folder holds files startrack did not write;
    ``reuse``: whether an earlier run's files may be there without ``overwrite`` (compare
    resumes or checks the run's identity; simulate refuses them)."""

    def __init__(self, out: str | Path, command: str, inputs: Iterable[str | Path] = (),
                 overwrite: bool = False, reuse: bool = True, what: str = "--out",
                 outputs: str = "") -> None:
        self.out, self.command, self.what = Path(out), command, what
        self.overwrite, self.reuse = overwrite, reuse
        #: a regular expression of the fixed names the run writes (checked before any work)
        self.outputs = re.compile(outputs) if outputs else None
        self.writer = Writer(inputs, overwrite=True)
        self._listed: list[str] = []
        self._fd: int | None = None

    # --- before any work ------------------------------------------------------------------
    def check(self) -> None:
        """Refuse now, without writing anything, a folder this run may not use."""
        st = _lstat(self.out, self.what)
        if st is None:
            _check_parents(self.out, self.what)
            return
        if not os.path.isdir(self.out):  # a symlink to a folder is used, never replaced
            raise OutputError(f"{self.what} {self.out}: exists and is not a folder")
        other = self.other_command()
        if other is not None:
            raise OutputError(f"{self.what} {self.out}: holds a `startrack {other}` run "
                              f"({MANIFEST_FILE}); {self.command} never replaces another "
                              "command's files, whatever --overwrite says; choose another "
                              "folder")
        if not (self.reuse or self.overwrite) and self.earlier():
            raise OutputError(f"{self.what} {self.out}: holds an earlier run's files; give "
                              "--overwrite to replace them, or choose another folder")
        unlisted = self.unlisted()
        if unlisted and not self.overwrite:
            names = ", ".join(unlisted[:_QUOTED]) + (", ..." if len(unlisted) > _QUOTED else "")
            raise OutputError(f"{self.what} {self.out}: holds {len(unlisted)} file(s) startrack "
                              f"did not write ({names}); give --overwrite to write there "
                              "anyway (they are kept), or choose another folder")
        taken = [n for n in unlisted if self.outputs is not None and self.outputs.fullmatch(n)
                 and self.writer.input_at(self.out / n) is None]  # an input: register's
        if taken:
            raise self._taken(taken[0])

    def _taken(self, name: str) -> OutputError:
        return OutputError(f"{self.what} {self.out}: holds {name}, which startrack did not "
                           f"write (it is not in {MANIFEST_FILE}) and {self.command} would "
                           "replace; startrack never replaces it, even with --overwrite: "
                           "move it away or choose another folder")

    def _manifest(self) -> dict:
        """The manifest's content ({} when there is none or it is unreadable)."""
        try:
            data = json.loads((self.out / MANIFEST_FILE).read_text())
        except (OSError, ValueError):
            return {}
        return data if isinstance(data, dict) and data.get("format") == MANIFEST_FORMAT else {}

    def other_command(self) -> str | None:
        """The command of the run whose files the folder lists, when it is another
        command than this run's and some of its files are still there."""
        command = self._manifest().get("command")
        if not isinstance(command, str) or command == self.command or not self.earlier():
            return None
        return command

    def _named(self) -> list[str]:
        """Every plain name the manifest lists, whether or not the file is there."""
        files = self._manifest().get("files")
        return [f for f in files if isinstance(f, str) and _plain(f)] \
            if isinstance(files, list) else []

    def earlier(self) -> list[str]:
        """The files an earlier startrack run listed here (and that are still there)."""
        return [f for f in self._named() if os.path.lexists(self.out / f)]

    def unlisted(self) -> list[str]:
        """The names in the folder that no startrack run listed (its own files aside)."""
        listed = set(self._named()) | set(self._listed)
        own = listed | {LOCK_FILE, MANIFEST_FILE}
        return sorted(name for name in os.listdir(self.out)
                      if name not in own and not _temporary_of(name, listed | {MANIFEST_FILE}))

    # --- while the run holds the folder ---------------------------------------------------
    def __enter__(self) -> RunFolder:
        import fcntl  # fcntl: POSIX only, the lock is taken only where it exists

        self.check()
        try:
            self.out.mkdir(parents=True, exist_ok=True)
            self._fd = os.open(self.out / LOCK_FILE, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW,
                               0o666)
        except OSError as exc:
            raise OutputError(f"{self.what} {self.out}: cannot use ({exc.strerror or exc})") \
                from None
        try:
            fcntl.flock(self._fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            self._release()
            raise OutputError(f"{self.what} {self.out}: another {self._holder()} is running "
                              f"there (it holds the lock {self.out / LOCK_FILE}); wait for it "
                              "or choose another folder") from None
        os.ftruncate(self._fd, 0)
        os.write(self._fd, f"{os.getpid()} {self.command}\n".encode())
        self.check()  # again, under the lock: the folder may have changed meanwhile
        named = self._named()
        self._listed = self.earlier()
        self._remove_stale_temporaries(named)
        _FOLDERS[os.path.realpath(self.out)] = self
        return self

    def __exit__(self, *exc) -> None:
        _FOLDERS.pop(os.path.realpath(self.out), None)
        self._release()

    def _holder(self) -> str:
        """The command holding the lock, as it wrote it in the lock file ("pid command")."""
        try:
            words = (self.out / LOCK_FILE).read_text().split()
        except (OSError, ValueError):
            words = []
        return words[1] if len(words) == 2 and words[1].isidentifier() else "startrack run"

    def _release(self) -> None:
        if self._fd is not None:
            os.close(self._fd)  # releases the lock; the file stays (unlinking it would race)
            self._fd = None

    def register(self, name: str) -> None:
        """List ``name`` (about to be written here) in the manifest first; refuse a name
        that is one of the run's inputs."""
        path = self.out / name
        hit = self.writer.input_at(path)
        if hit is not None:
            raise OutputError(f"{self.what} {self.out}: would write {path}, which is the input "
                              f"{hit}; refusing to overwrite an input")
        if name in self._listed or name == MANIFEST_FILE:
            return
        if os.path.lexists(path):  # there, and no startrack run listed it: the user's
            raise self._taken(name)
        self._listed.append(name)
        self._write_manifest()

    def _write_manifest(self) -> None:
        _FOLDERS.pop(os.path.realpath(self.out), None)  # the manifest does not list itself
        try:
            with atomic_path(self.out / MANIFEST_FILE, self.what) as tmp:
                Path(tmp).write_text(json.dumps({"format": MANIFEST_FORMAT,
                                                 "command": self.command,
                                                 "files": sorted(self._listed)}, indent=1))
        finally:
            _FOLDERS[os.path.realpath(self.out)] = self

    def remove_earlier(self, keep: Iterable[str] = ()) -> list[str]:
        """Delete the files earlier runs listed (not ``keep``); returns their names."""
        keep = set(keep)
        gone = []
        for name in self.earlier():
            if name in keep:
                continue
            path = self.out / name
            if self.writer.input_at(path) is not None:  # what this run reads stays
                continue
            if os.path.isfile(path) and not os.path.islink(path):
                with contextlib.suppress(FileNotFoundError):
                    path.unlink()
                gone.append(name)
        self._listed = [n for n in self._listed if n not in gone]
        self._write_manifest()
        return gone

    def _remove_stale_temporaries(self, named: Iterable[str] = ()) -> None:
        """Temporary files of this folder's listed files (``named``: listed whether or not
        the file itself is there: a killed run's truth.csv never appeared) that a killed
        run left (SIGKILL runs no clean-up); safe under the lock."""
        listed = set(self._listed) | set(named) | {MANIFEST_FILE}
        for name in os.listdir(self.out):
            if _temporary_of(name, listed) and os.path.isfile(self.out / name):
                with contextlib.suppress(FileNotFoundError):
                    os.unlink(self.out / name)


def _plain(name: str) -> bool:
    """A manifest entry is a plain file name in the folder (never a path out of it)."""
    return bool(name) and "/" not in name and name not in (".", "..", LOCK_FILE)


def _temporary_of(name: str, listed: set[str]) -> bool:
    """Whether ``name`` is atomic_path's temporary file for one of the ``listed`` files."""
    return any(name.startswith(f".{own}.") and _TEMP_TAIL.fullmatch(name[len(own) + 2:])
               for own in listed)
