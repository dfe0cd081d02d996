"""report.md of a comparison: how to read it, what was run (camera, sky, frames, budget,
threshold, warm-up, machine load: startrack.bench._report_run), the summary tables with
Wilson intervals on every rate, the plots, the failed frames with why and the one command
that replays each, and the provenance (the exact command)."""

from __future__ import annotations

import datetime as dt
import os
import platform
import shlex
import subprocess
import sys
from importlib import metadata
from pathlib import Path

import pandas as pd

from startrack.bench._conditions import EXTRA_COLUMNS, VARIABLES, is_default
from startrack.bench._plots import SHORT, wilson
from startrack.bench._report_run import (
    HOW_TO_READ,
    description_rows,
    first_frame_lines,
    machine_load,
)
from startrack.io import atomic_text

REPORT_FILE = "report.md"
LIBRARIES = ("numpy", "scipy", "pandas", "astropy", "opencv-python-headless",
             "matplotlib", "click")
#: failed frames listed per method and kind (wrong, not solved); the rest are counted
MAX_LISTED = 10
#: options that change where or how fast a run goes, not its frames (dropped on replay)
NOT_REPLAYED = ("out_dir", "jobs", "scheduler", "resume", "replay")


#: what makes a run's numbers: "+dirty" means one of these differs from the commit (a run
#: that writes its own results under docs/ must not mark the next run of `make results` dirty)
CODE_PATHS = ("startrack", "scripts", "configs", "data", "setup.py", "pyproject.toml")


def git_commit() -> str | None:
    """The checkout's commit (with "+dirty" when its code has changes), None when installed."""
    root = Path(__file__).resolve().parents[2]
    if not (root / ".git").exists():
        return None
    try:
        commit = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"],
                                capture_output=True, text=True, timeout=10, check=True)
        dirty = subprocess.run(["git", "-C", str(root), "status", "--porcelain", "--", *CODE_PATHS],
                               capture_output=True, text=True, timeout=10, check=True)
    except (OSError, subprocess.SubprocessError):
        return None
    return commit.stdout.strip() + ("+dirty" if dirty.stdout.strip() else "")


def _cpu() -> str:
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    return f"{line.split(':', 1)[1].strip()} ({os.cpu_count()} CPUs)"
    except OSError:
        pass
    return f"{platform.processor() or platform.machine()} ({os.cpu_count()} CPUs)"


def provenance(command: str) -> dict[str, str]:
    """Who ran what where: version, commit, date, host, CPU, Python, libraries, command."""
    from startrack import __version__

    libs = []
    for name in LIBRARIES:
        try:
            libs.append(f"{name} {metadata.version(name)}")
        except metadata.PackageNotFoundError:
            continue
    return {
        "startrack": __version__,
        "git commit": git_commit() or "(not a checkout)",
        "date (UTC)": dt.datetime.now(dt.UTC).strftime("%Y-%m-%d %H:%M:%S"),
        "host": platform.node(),
        "CPU": _cpu(),
        "Python": f"{platform.python_version()} ({sys.executable})",
        "platform": platform.platform(),
        "libraries": ", ".join(libs),
        "command": command,
    }


def command_line(ctx, drop: tuple[str, ...] = ()) -> list[str]:
    """The command as given, rebuilt from a click context's options (exact, also when
    called from Python), without the options named in ``drop``."""
    from click.core import ParameterSource

    words = ["startrack", ctx.info_name or "compare"]
    for param in ctx.command.params:
        if param.name in drop or ctx.get_parameter_source(param.name) in (
                ParameterSource.DEFAULT, None):
            continue
        value = ctx.params[param.name]
        if param.is_flag and param.secondary_opts:
            words.append(param.opts[0] if value else param.secondary_opts[0])
        elif param.is_flag:
            if value:
                words.append(param.opts[0])
        elif value is not None:
            words += [param.opts[0], str(value)]
    return words


def _pct(rate: float, low: float, high: float) -> str:
    return f"{rate:.1%} [{low:.1%}, {high:.1%}]"


def _pair(median: float, p95: float) -> str:
    """"9.1 / 25.3": a median and a 95th percentile; "-" when there is none."""
    return "-" if pd.isna(median) else f"{median:.1f} / {p95:.1f}"


def condition_columns(summary: pd.DataFrame) -> list[str]:
    """The swept variables a table shows: the first four always, the others (the camera's
    and the sensor and space effects) where a level is not their default."""
    return [v for v in VARIABLES if v in summary and (
        v in VARIABLES[:4] or not all(is_default(v, x) for x in summary[v]))]


def _column_name(variable: str) -> str:
    """A swept variable's column head: the effects' and camera's short names (their
    columns sit beside many), the others' plain ones."""
    return EXTRA_COLUMNS.get(variable) or SHORT.get(variable, variable)


def summary_table(summary: pd.DataFrame) -> str:
    """A Markdown table: one row per (condition, method), rates with 95% intervals, the
    correctness threshold, the boresight, roll and total errors apart, precision and
    recall side by side.

    Built here rather than by ``DataFrame.to_markdown``: that needs ``tabulate`` (not a
    dependency) for a table whose cells are formatted strings anyway."""
    variables = condition_columns(summary)
    head = ("| cond | " + " | ".join(_column_name(v) for v in variables)
            + " | method | frames | solved [95% CI] | correct [95% CI] | wrong [95% CI] | "
            "threshold arcsec | boresight error arcsec (median / p95) | roll error arcsec "
            "(median / p95) | total error arcsec (median / p95) | star precision | "
            "star recall | time ms (median / p95) |")
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for _, r in summary.iterrows():
        n = int(r["frames"])
        cells = [str(r["condition"]), *(f"{r[v]:g}" for v in variables), str(r["method"]),
                 str(n)]
        for column in ("solved_rate", "correct_rate", "wrong_rate"):
            k = round(float(r[column]) * n)
            low, high = wilson(k, n)
            cells.append(_pct(float(r[column]), float(low), float(high)))
        cells += [f"{r.get('threshold_arcsec', float('nan')):.0f}",
                  _pair(r["boresight_median_arcsec"], r.get("boresight_p95_arcsec")),
                  _pair(r["roll_median_arcsec"], r.get("roll_p95_arcsec")),
                  _pair(r["error_median_arcsec"], r["error_p95_arcsec"]),
                  f"{r['star_precision']:.3f}", f"{r['star_recall']:.3f}",
                  f"{r['time_median_ms']:.2f} / {r['time_p95_ms']:.2f}"]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _why(row) -> str:
    """Why a listed frame failed, in words."""
    reason = row.get("reason")
    if not isinstance(reason, str) or not reason:
        return ""
    return f" ({REASONS.get(reason, reason)})"


def failures(frames: pd.DataFrame, replay: list[str], replay_for=None) -> list[str]:
    """Markdown lines listing wrong and unsolved frames with why and their replay command:
    ``replay`` + ``--replay CONDITION,FRAME``, or ``replay_for(row)`` when given (a
    --frames-dir run: the identify command of the frame's file)."""
    lines = []
    for kind, mask in (("wrong", frames["wrong"].astype(bool)),
                       ("not solved", ~frames["solved"].astype(bool))):
        for method, rows in frames[mask].groupby("method", sort=False):
            lines.append(f"\n**{method}, {kind}: {len(rows)} frame(s)**\n")
            for _, r in rows.head(MAX_LISTED).iterrows():
                cmd = shlex.join(replay_for(r) if replay_for is not None else [
                    *replay, "--replay", f"{int(r['condition'])},{int(r['frame'])}"])
                lines.append(f"- condition {int(r['condition'])}, frame {int(r['frame'])}"
                             f"{_why(r)}: `{cmd}`")
            if len(rows) > MAX_LISTED:
                lines.append(f"- ... and {len(rows) - MAX_LISTED} more (frames.csv)")
    return lines or ["\nNo frame was wrong or unsolved."]


def write_report(result, command: list[str], replay: list[str], replay_for=None) -> Path:
    """Write report.md beside the CSVs of a finished run (``RunOutputs``); ``replay_for``
    as in :func:`failures`. It opens with how to read it and what the run was, so it
    stands alone."""
    out = Path(result.out)
    frames = pd.read_csv(result.frames_csv)
    prov = provenance(shlex.join(command))
    lines = ["# startrack compare report", "", "## How to read this", "", HOW_TO_READ, "",
             "## Run", ""]
    lines += description_rows(result.description, result.load_at_start, machine_load())
    lines += ["", "## Summary", "", summary_table(result.summary), "",
              "Load times (sky; database, prepare and warm-up per method): " + ", ".join(
                  f"{k} {v:.2f} s" for k, v in result.load_seconds.items()), "",
              "First timed frames (a method's one-time costs would show here):", ""]
    lines += first_frame_lines(frames)
    lines += ["", "## Plots", ""]
    lines += [f"![{p.stem}]({p.name})" for p in result.plots] or ["(nothing was swept)"]
    lines += ["", "## Failed frames", "",
              "Each command reruns one frame through every method and prints what each "
              "answered and why; frames.csv holds the true and solved quaternions (true_q*, "
              "solved_q*) and the reason of every frame."]
    lines += failures(frames, replay, replay_for)
    lines += ["", "## Provenance", "", "| | |", "|---|---|"]
    lines += [f"| {k} | {v.replace('|', '/')} |" for k, v in prov.items()]
    lines += ["", "Files: frames.csv (per frame and method), summary.csv (per condition), "
              "db.csv (load times), run.json (the run's identity)."]
    path = out / REPORT_FILE
    with atomic_text(path) as fh:
        fh.write("\n".join(lines) + "\n")
    return path


#: a frames.csv ``reason`` in words
REASONS = {
    "no_match": "no hypothesis passed verification",
    "too_few_stars": "too few stars to form a pattern",
    "timeout": "ran out of time",
    "unverified": "an answer without enough evidence, refused",
    "wrong_star": "a reported star is the wrong catalog star",
    "pointing": "the boresight is beyond the threshold",
}


def condition_text(condition: dict) -> str:
    """A condition in words: "noise 2 px, 0 false stars, 0% missing, mag noise 0"."""
    parts = [f"{SHORT.get(k, k)} {v:g}" for k, v in condition.items()]
    return ", ".join(parts)


def replay_text(rows: list[dict]) -> str:
    """What each method answered on one replayed frame, one block per method: its
    verdict and, when not correct, why."""
    lines = []
    for r in rows:
        verdict = "wrong" if r["wrong"] else "correct" if r["correct"] else "not solved"
        why = REASONS.get(r.get("reason") or "", r.get("reason") or "")
        head = f"{r['method']}: {verdict}" + (f": {why}" if why else "")
        lines.append(f"{head} ({r['method_ms']:.2f} ms)")
        lines.append(f"  stars: {r['n_observed']} observed ({r['n_real_observed']} real), "
                     f"{r['n_identified']} reported, {r['n_id_wrong']} of them wrong")
        if r["solved"]:
            lines.append(f"  errors: boresight {r['boresight_error_arcsec']:.1f} arcsec "
                         f"(threshold {r['threshold_arcsec']:.0f}), roll "
                         f"{r['roll_error_arcsec']:.1f}, total {r['error_arcsec']:.1f}")
        true_q = [r[f"true_q{c}"] for c in "wxyz"]
        lines.append("  true quaternion [w, x, y, z]:   "
                     + ", ".join(f"{v:+.9f}" for v in true_q))
        if r["solved"]:
            solved_q = [r[f"solved_q{c}"] for c in "wxyz"]
            lines.append("  solved quaternion [w, x, y, z]: "
                         + ", ".join(f"{v:+.9f}" for v in solved_q))
    return "\n".join(lines)

__all__ = [
    "LIBRARIES", "MAX_LISTED", "NOT_REPLAYED", "REASONS", "REPORT_FILE", "command_line",
    "condition_columns", "condition_text", "failures", "provenance", "replay_text",
    "summary_table", "write_report",
]
