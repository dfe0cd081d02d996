"""One comparison run end to end: check the out folder, run the pending units, then write
the canonical frames.csv, summary.csv, db.csv and the plots."""

from __future__ import annotations

import csv
import dataclasses
import time
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from startrack.bench._conditions import VARIABLES, set_extras
from startrack.bench._metrics import summarise
from startrack.bench._plots import plot_sweeps
from startrack.bench._report_run import lost_in_space_description, machine_load
from startrack.bench._runner import COLUMNS, RunSpec, connect, execute, load_bench, progress_bar
from startrack.bench._store import (
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
from startrack.errors import InputError
from startrack.io import RunFolder, atomic_text

SUMMARY_FILE = "summary.csv"
DB_FILE = "db.csv"
GROUP_COLUMNS = ["condition", *VARIABLES, "method"]
#: the fixed names a comparison writes (its plots' names depend on what it sweeps)
COMPARE_OUTPUTS = r"frames\.csv|summary\.csv|db\.csv|report\.md|run\.json|time_ratio\.csv"


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
    #: what the run was, for report.md's "Run" table (startrack.bench._report_run)
    description: dict = field(default_factory=dict)
    #: the machine's load average (1, 5, 15 min) when the run started; None: unknown
    load_at_start: tuple[float, float, float] | None = None


def lost_in_space_identity(spec: RunSpec) -> dict:
    """What run.json records of a lost-in-space comparison (its mode, options, code)."""
    return run_identity({"mode": "lost_in_space", **spec.to_json()})


def same_or_new(out: Path, identity: dict, resume: bool | None) -> bool:
    """Whether ``out`` holds the run ``identity`` (False: none, or ``resume`` is False);
    a different run of any mode is refused unless ``resume`` is False (--no-resume)."""
    if resume is False or not (out / RUN_FILE).exists():
        return False
    stored = read_run(out)
    if stored is None or not same_run(stored, identity):
        what = ", ".join(differences(stored, identity)) if stored else "unreadable run.json"
        raise InputError(f"{out}: holds a different comparison run (differs in: {what}); "
                         "use --no-resume to start over or choose another --out")
    return True


def _resumable(spec: RunSpec, out: Path, resume: bool | None) -> dict:
    """The complete units to keep from an earlier run in ``out`` (none: start over)."""
    if not same_or_new(out, lost_in_space_identity(spec), resume):
        return {}
    return read_done(out / FRAMES_FILE, COLUMNS, list(spec.methods))


def run_in_folder(out: str | Path, identity: dict, run, *, resume: bool | None = None,
                  overwrite: bool = False, inputs=()):
    """``run(out)`` (a comparison that cannot resume: ``compare --mode tracking``) in the
    folder ``out``, holding its lock; an earlier run's listed files are removed first, and
    run.json records ``identity`` once it is done. Returns what ``run`` returns."""
    folder = RunFolder(out, "compare", inputs, overwrite=overwrite,
                       outputs=COMPARE_OUTPUTS)
    folder.check()
    with folder:
        same_or_new(folder.out, identity, resume)
        folder.remove_earlier()
        result = run(folder.out)
        write_run(folder.out, identity)
    return result


def _run_pending(spec: RunSpec, folder: RunFolder, done: dict, jobs: int, client,
                 progress: bool) -> tuple[int, int]:
    """Run the units not yet in frames.csv, appending each as it finishes."""
    out = folder.out
    if not done:
        folder.remove_earlier()  # starting over: no earlier run's file outlives it
    write_run(out, lost_in_space_identity(spec))
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
                   progress: bool = False, announce=None, overwrite: bool = False,
                   inputs=(), finish=None) -> RunOutputs:
    """Run (or finish) the comparison ``spec`` into the folder ``out``.

    ``resume``: None resumes when ``out`` holds the same run and refuses a different one;
    True the same; False starts over. ``announce()`` is called once the run holds the
    folder's lock (a second run on one folder fails before it says anything).
    ``overwrite``: use ``out`` although it holds files startrack did not write;
    ``inputs``: files the run reads, never written (startrack.io._run_folder);
    ``finish(result)`` writes more files (report.md) while the run still holds the folder.
    """
    t0, load_at_start = time.perf_counter(), machine_load()
    out = Path(out)
    folder = RunFolder(out, "compare", inputs, overwrite=overwrite,
                       outputs=COMPARE_OUTPUTS)
    folder.check()
    # Load in this process first: a bad method or sky fails before anything is written,
    # and the database load times are measured once, here.
    bench = load_bench(spec)
    client = connect(scheduler) if scheduler is not None else None
    try:
        with folder:
            result = _locked_run(spec, folder, bench, jobs, client, resume, progress, t0,
                                 announce)
            workers = (f"a Dask cluster ({scheduler})" if client is not None else
                       f"{jobs} worker process(es)" if jobs > 1 else "1 process, in order")
            result = dataclasses.replace(
                result, description=lost_in_space_description(spec, workers),
                load_at_start=load_at_start)
            if finish is not None:
                finish(result)
            return result
    finally:
        if client is not None:
            client.close()


def _locked_run(spec: RunSpec, folder: RunFolder, bench, jobs: int, client,
                resume: bool | None, progress: bool, t0: float, announce) -> RunOutputs:
    out = folder.out
    done = _resumable(spec, out, resume)
    if announce is not None:
        announce()
    units_run, units_done = _run_pending(spec, folder, done, jobs, client, progress)
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
        **{short: summary[var].map("{:g}".format) for var, short in set_extras(summary)},
        "method": summary["method"],
        "n": summary["frames"],
        "solved": summary["solved_rate"].map("{:.1%}".format),
        "correct": summary["correct_rate"].map("{:.1%}".format),
        "wrong": summary["wrong"],
        "prec": summary["star_precision"].map("{:.3f}".format),
        "recall": summary["star_recall"].map("{:.3f}".format),
        "thresh_as": summary["threshold_arcsec"].map("{:.0f}".format),
        "bore_med_as": summary["boresight_median_arcsec"].map("{:.1f}".format),
        "roll_med_as": summary["roll_median_arcsec"].map("{:.1f}".format),
        "total_med_as": summary["error_median_arcsec"].map("{:.1f}".format),
        "t_med_ms": summary["time_median_ms"].map("{:.2f}".format),
        "t_p95_ms": summary["time_p95_ms"].map("{:.2f}".format),
    })
    return table.to_string(index=False)

__all__ = [
    "DB_FILE", "GROUP_COLUMNS", "RunOutputs", "SUMMARY_FILE", "format_table",
    "lost_in_space_identity", "run_comparison", "run_in_folder", "same_or_new",
]
