"""One comparison run end to end: check the out folder, run the pending units, then write
the canonical frames.csv, summary.csv, db.csv and the plots."""

from __future__ import annotations

import contextlib
import csv
import os
import re
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from startrack.bench.conditions import VARIABLES
from startrack.bench.metrics import summarise
from startrack.bench.plots import plot_sweeps
from startrack.bench.runner import COLUMNS, RunSpec, connect, execute, load_bench, progress_bar
from startrack.bench.store import (
    FRAMES_FILE,
    RUN_FILE,
    FramesWriter,
    differences,
    read_done,
    read_run,
    run_identity,
    same_run,
    write_canonical,
    write_run,
)
from startrack.cache import atomic_text
from startrack.errors import InputError
from startrack.outputs import check_out_folder

SUMMARY_FILE = "summary.csv"
LOCK_FILE = ".lock"
# mkstemp names of atomic writes: .<file>.<8 random chars><suffix>
TEMP_NAME = re.compile(r"^\.[^.].*\.[A-Za-z0-9_]{8}(\.[A-Za-z0-9]+)?$")
DB_FILE = "db.csv"
GROUP_COLUMNS = ["condition", *VARIABLES, "method"]


@dataclass(frozen=True)
class RunOutputs:
    """Where a run's files are, and what it did."""

    out: Path
    frames_csv: Path
    summary_csv: Path
    db_csv: Path
    plots: list[Path]
    summary: pd.DataFrame
    units_run: int
    units_resumed: int
    load_seconds: dict[str, float]
    wall_seconds: float


def _resumable(spec: RunSpec, out: Path, resume: bool | None) -> dict:
    """The complete units to keep from an earlier run in ``out`` (none: start over)."""
    if resume is False or not (out / RUN_FILE).exists():
        return {}
    stored = read_run(out)
    identity = run_identity(spec.to_json())
    if stored is None or not same_run(stored, identity):
        what = ", ".join(differences(stored, identity)) if stored else "unreadable run.json"
        raise InputError(f"{out}: holds a different comparison run (differs in: {what}); "
                         "use --no-resume to start over or choose another --out")
    return read_done(out / FRAMES_FILE, COLUMNS, list(spec.methods))


def _clear_outputs(out: Path) -> None:
    for path in [out / SUMMARY_FILE, out / DB_FILE, out / "report.md",
                 *out.glob("plot_*.png"), *out.glob("heatmap_*.png")]:
        path.unlink(missing_ok=True)


def _run_pending(spec: RunSpec, out: Path, done: dict, jobs: int, client,
                 progress: bool) -> tuple[int, int]:
    """Run the units not yet in frames.csv, appending each as it finishes."""
    if not done:
        _clear_outputs(out)
    write_run(out, run_identity(spec.to_json()))
    writer = FramesWriter(out / FRAMES_FILE, COLUMNS, done)
    pending = [u for u in spec.units() if u not in done]
    bar = progress_bar(len(spec.units()), len(done), progress)
    units = execute(spec, pending, jobs=jobs, client=client)
    try:
        for _unit, rows in units:
            writer.add(rows)
            bar.update(1)
    finally:
        units.close()  # on SIGTERM or an error: stop the workers now, not at GC
        writer.close()
        bar.close()
    return len(pending), len(done)


def run_comparison(spec: RunSpec, out: str | Path, *, jobs: int = 1,
                   scheduler: str | None = None, resume: bool | None = None,
                   progress: bool = False, announce=None) -> RunOutputs:
    """Run (or finish) the comparison ``spec`` into the folder ``out``.

    ``resume``: None resumes when ``out`` holds the same run and refuses a different one;
    True the same; False starts over. ``announce()`` is called once the run holds the
    folder's lock (a second run on one folder fails before it says anything).
    """
    t0 = time.perf_counter()
    out = Path(out)
    check_out_folder(out, overwrite=True)
    # Load in this process first: a bad method or sky fails before anything is written,
    # and the database load times are measured once, here.
    bench = load_bench(spec)
    client = connect(scheduler) if scheduler is not None else None
    try:
        with exclusive_lock(out):
            return _locked_run(spec, out, bench, jobs, client, resume, progress, t0,
                               announce)
    finally:
        if client is not None:
            client.close()


@contextlib.contextmanager
def exclusive_lock(out: Path) -> Iterator[Path]:
    """Hold ``out/.lock`` (flock) for the whole run: a second run on one folder would
    interleave its rows with this one's."""
    import fcntl

    out.mkdir(parents=True, exist_ok=True)
    lock = out / LOCK_FILE
    fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o666)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise InputError(f"--out {out}: another compare is running there (it holds "
                             f"the lock {lock}); wait for it or choose another --out") \
                from None
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode())
        yield lock
    finally:
        os.close(fd)  # releases the lock; the file stays (unlinking it would race)


def _remove_stale_temporaries(out: Path) -> None:
    """Temporary files a killed run left (SIGKILL runs no clean-up); safe under the lock."""
    for path in out.iterdir():
        if TEMP_NAME.match(path.name) and path.is_file():
            path.unlink(missing_ok=True)


def _locked_run(spec: RunSpec, out: Path, bench, jobs: int, client, resume: bool | None,
                progress: bool, t0: float, announce) -> RunOutputs:
    _remove_stale_temporaries(out)
    done = _resumable(spec, out, resume)
    if announce is not None:
        announce()
    units_run, units_done = _run_pending(spec, out, done, jobs, client, progress)
    frames_csv = out / FRAMES_FILE
    write_canonical(frames_csv, COLUMNS, list(spec.methods))

    frames = pd.read_csv(frames_csv)
    summary = summarise(frames, GROUP_COLUMNS)
    summary_csv = out / SUMMARY_FILE
    with atomic_text(summary_csv) as fh:
        summary.to_csv(fh, index=False, float_format="%.6g", lineterminator="\n")
    db_csv = out / DB_FILE
    with atomic_text(db_csv) as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(["stage", "seconds"])
        for stage, seconds in bench.load_seconds.items():
            w.writerow([stage if stage == "sky" else f"{stage} database+prepare",
                        f"{seconds:.4f}"])
    plots = plot_sweeps(summary, list(spec.conditions), list(spec.methods), out)
    return RunOutputs(out, frames_csv, summary_csv, db_csv, plots, summary,
                      units_run, units_done, dict(bench.load_seconds),
                      time.perf_counter() - t0)


def format_table(summary: pd.DataFrame) -> str:
    """The summary as a readable fixed-width table."""
    table = pd.DataFrame({
        "cond": summary["condition"],
        "noise": summary["noise_px"].map("{:g}".format),
        "false": summary["false_stars"],
        "miss": summary["missing"].map("{:g}".format),
        "magn": summary["mag_noise"].map("{:g}".format),
        "method": summary["method"],
        "n": summary["frames"],
        "solved": summary["solved_rate"].map("{:.1%}".format),
        "correct": summary["correct_rate"].map("{:.1%}".format),
        "wrong": summary["wrong"],
        "prec": summary["star_precision"].map("{:.3f}".format),
        "recall": summary["star_recall"].map("{:.3f}".format),
        "err_med_as": summary["error_median_arcsec"].map("{:.1f}".format),
        "bore_med_as": summary["boresight_median_arcsec"].map("{:.1f}".format),
        "t_med_ms": summary["time_median_ms"].map("{:.2f}".format),
        "t_p95_ms": summary["time_p95_ms"].map("{:.2f}".format),
    })
    return table.to_string(index=False)
