"""The run's files on disk: run.json (what was asked) and frames.csv (what is done).

frames.csv is written as the run goes, one flushed append per finished work unit, and
read back tolerantly: a torn last line (an interrupted write) and incomplete units are
dropped, so a resumed run redoes exactly the units that were not finished.
"""

from __future__ import annotations

import csv
import functools
import io
import json
import math
from pathlib import Path

from startrack.errors import InputError
from startrack.io import atomic_text

RUN_FILE = "run.json"
FRAMES_FILE = "frames.csv"
RUN_FORMAT = 1


def format_value(value) -> str:
    """One CSV cell, formatted the same way whichever process made it (NaN: empty)."""
    if isinstance(value, bool):
        return "1" if value else "0"
    if isinstance(value, float):
        return "" if math.isnan(value) else repr(value)
    return str(value)


def format_rows(rows: list[dict], columns: list[str]) -> list[list[str]]:
    return [[format_value(row[c]) for c in columns] for row in rows]


@functools.lru_cache(maxsize=1)
def code_fingerprint() -> str:
    """A hash of the package's source (CLI aside): a resume must not mix the numbers of
    two versions of a matcher, the verification or the frame generator."""
    import hashlib

    import startrack

    root = Path(startrack.__file__).parent
    digest = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(root).as_posix()
        if not rel.startswith("cli/"):
            digest.update(rel.encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()[:16]


def read_run(out: Path) -> dict | None:
    """The stored run identity, or None when there is none (or it is unreadable)."""
    path = out / RUN_FILE
    if not path.is_file():
        return None
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def write_run(out: Path, identity: dict) -> None:
    with atomic_text(out / RUN_FILE) as fh:
        json.dump({"format": RUN_FORMAT, **identity}, fh, indent=2, sort_keys=True)
        fh.write("\n")


def same_run(stored: dict | None, identity: dict) -> bool:
    """Whether run.json describes the run ``identity`` (after a JSON round trip)."""
    if stored is None:
        return False
    expected = json.loads(json.dumps({"format": RUN_FORMAT, **identity}))
    return stored == expected


def run_identity(spec_json: dict) -> dict:
    """What run.json records: the run's options and the code that produces its numbers."""
    return {**spec_json, "code": code_fingerprint()}


def differences(stored: dict, identity: dict) -> list[str]:
    expected = json.loads(json.dumps({"format": RUN_FORMAT, **identity}))
    keys = sorted(set(stored) | set(expected))
    return [k for k in keys if stored.get(k) != expected.get(k)]


def read_done(path: Path, columns: list[str], methods: list[str]) -> dict[tuple, list]:
    """Complete units already in frames.csv: {(condition, frame): rows as cell lists}.

    A unit counts only when every method has exactly one intact row; anything else (a
    torn last line, a half-written unit, a file from another version) is dropped.
    """
    if not path.is_file():
        return {}
    text = path.read_text(errors="replace")
    if not text.endswith("\n"):
        text = text[: text.rfind("\n") + 1]  # the last line was torn mid-write
    reader = csv.reader(io.StringIO(text))
    header = next(reader, None)
    if header != columns:
        return {}
    ci, fi, mi = columns.index("condition"), columns.index("frame"), columns.index("method")
    units: dict[tuple, dict[str, list]] = {}
    for cells in reader:
        if len(cells) != len(columns) or cells[mi] not in methods:
            continue
        try:
            unit = (int(cells[ci]), int(cells[fi]))
        except ValueError:
            continue
        units.setdefault(unit, {})[cells[mi]] = cells
    return {u: [rows[m] for m in methods] for u, rows in units.items()
            if set(rows) == set(methods)}


class FramesWriter:
    """Appends each finished unit's rows to frames.csv and flushes them at once."""

    def __init__(self, path: Path, columns: list[str], done: dict[tuple, list]) -> None:
        self.path = path
        self.columns = columns
        # Start from a clean file holding only the complete units (drops torn lines).
        with atomic_text(path) as fh:
            writer = csv.writer(fh, lineterminator="\n")
            writer.writerow(columns)
            for unit in sorted(done):
                writer.writerows(done[unit])
        self._fh = open(path, "a", newline="")  # noqa: SIM115 - closed in close()
        self._writer = csv.writer(self._fh, lineterminator="\n")

    def add(self, rows: list[dict]) -> None:
        buffer = io.StringIO()
        csv.writer(buffer, lineterminator="\n").writerows(format_rows(rows, self.columns))
        self._fh.write(buffer.getvalue())  # one write per unit
        self._fh.flush()

    def close(self) -> None:
        self._fh.close()


def write_canonical(path: Path, columns: list[str], methods: list[str]) -> int:
    """Rewrite frames.csv sorted by (condition, frame, method order); returns the rows."""
    done = read_done(path, columns, methods)
    if not done:
        raise InputError(f"{path}: no complete rows to summarise")
    with atomic_text(path) as fh:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(columns)
        for unit in sorted(done):
            writer.writerows(done[unit])
    return sum(len(rows) for rows in done.values())

__all__ = [
    "FRAMES_FILE", "FramesWriter", "RUN_FILE", "RUN_FORMAT", "code_fingerprint", "differences",
    "format_rows", "format_value", "read_done", "read_run", "run_identity", "same_run",
    "write_canonical", "write_run",
]
