"""report.md of a comparison: what was run (provenance, the exact command), the summary
tables with Wilson intervals on every rate, the plots, and the failed frames with the one
command that replays each."""

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

from startrack.bench.conditions import set_extras
from startrack.bench.plots import wilson
from startrack.io._writer import atomic_text

REPORT_FILE = "report.md"
LIBRARIES = ("numpy", "scipy", "pandas", "astropy", "opencv-python-headless",
             "matplotlib", "click")
#: failed frames listed per method and kind (wrong, not solved); the rest are counted
MAX_LISTED = 10
#: options that change where or how fast a run goes, not its frames (dropped on replay)
NOT_REPLAYED = ("out_dir", "jobs", "scheduler", "resume", "replay")


def _git_commit() -> str | None:
    """The checkout's commit (with "+dirty" when it has changes), None when installed."""
    root = Path(__file__).resolve().parents[2]
    if not (root / ".git").exists():
        return None
    try:
        commit = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"],
                                capture_output=True, text=True, timeout=10, check=True)
        dirty = subprocess.run(["git", "-C", str(root), "status", "--porcelain"],
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
        "git commit": _git_commit() or "(not a checkout)",
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


def summary_table(summary: pd.DataFrame) -> str:
    """A Markdown table: one row per (condition, method), rates with 95% intervals.

    Built here rather than by ``DataFrame.to_markdown``: that needs ``tabulate`` (not a
    dependency) for a table whose cells are formatted strings anyway."""
    extras = set_extras(summary)  # camera and effect axes, when the run sets them
    head = ("| cond | noise px | false | missing | mag noise | "
            + "".join(f"{short} | " for _, short in extras)
            + "method | frames | solved "
            "[95% CI] | correct [95% CI] | wrong [95% CI] | star precision | error median "
            "arcsec | error p95 arcsec | time median ms | time p95 ms |")
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for _, r in summary.iterrows():
        n = int(r["frames"])
        cells = [str(r["condition"]), f"{r['noise_px']:g}", f"{int(r['false_stars'])}",
                 f"{r['missing']:g}", f"{r['mag_noise']:g}",
                 *(f"{r[var]:g}" for var, _ in extras), str(r["method"]), str(n)]
        for column in ("solved_rate", "correct_rate", "wrong_rate"):
            k = round(float(r[column]) * n)
            low, high = wilson(k, n)
            cells.append(_pct(float(r[column]), float(low), float(high)))
        cells += [f"{r['star_precision']:.3f}", f"{r['error_median_arcsec']:.1f}",
                  f"{r['error_p95_arcsec']:.1f}", f"{r['time_median_ms']:.2f}",
                  f"{r['time_p95_ms']:.2f}"]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def failures(frames: pd.DataFrame, replay: list[str], replay_for=None) -> list[str]:
    """Markdown lines listing wrong and unsolved frames with their replay command:
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
                lines.append(f"- condition {int(r['condition'])}, frame {int(r['frame'])}: "
                             f"`{cmd}`")
            if len(rows) > MAX_LISTED:
                lines.append(f"- ... and {len(rows) - MAX_LISTED} more (frames.csv)")
    return lines or ["\nNo frame was wrong or unsolved."]


def write_report(result, command: list[str], replay: list[str], replay_for=None) -> Path:
    """Write report.md beside the CSVs of a finished run (``RunOutputs``); ``replay_for``
    as in :func:`failures`."""
    out = Path(result.out)
    frames = pd.read_csv(result.frames_csv)
    prov = provenance(shlex.join(command))
    lines = ["# startrack compare report", "", "## Provenance", "",
             "| | |", "|---|---|"]
    lines += [f"| {k} | {v.replace('|', '/')} |" for k, v in prov.items()]
    lines += ["", "## Summary", "",
              "Rates are over the frames of each condition; brackets are 95% Wilson score "
              "intervals. A solution is correct when every reported star is right and the "
              "boresight is within the threshold; wrong when accepted but not correct.",
              "", summary_table(result.summary), "",
              "Load times (sky; database, prepare and warm-up per method): " + ", ".join(
                  f"{k} {v:.2f} s" for k, v in result.load_seconds.items()), "",
              "Times are warm: in every worker process, every method first solves a "
              "throwaway frame (compiling its kernels and filling its lazy tables; "
              "images: one extraction too) before its first timed frame, so no time above "
              "holds a compiler, a cache fill or an import.", ""]
    lines += ["## Plots", ""]
    lines += [f"![{p.stem}]({p.name})" for p in result.plots] or ["(nothing was swept)"]
    lines += ["", "## Failed frames", "",
              "Each command reruns one frame through every method and prints what each "
              "answered; frames.csv holds the true and solved quaternions (true_q*, "
              "solved_q*) of every frame."]
    lines += failures(frames, replay, replay_for)
    lines += ["", "Files: frames.csv (per frame and method), summary.csv (per condition), "
              "db.csv (load times), run.json (the run's identity)."]
    path = out / REPORT_FILE
    with atomic_text(path) as fh:
        fh.write("\n".join(lines) + "\n")
    return path


def replay_text(rows: list[dict]) -> str:
    """What each method answered on one replayed frame, one block per method."""
    lines = []
    for r in rows:
        verdict = "wrong" if r["wrong"] else "correct" if r["correct"] else (
            "solved" if r["solved"] else "not solved")
        lines.append(f"{r['method']}: {verdict}; {r['n_identified']} stars reported "
                     f"({r['n_id_wrong']} wrong) of {r['n_observed']} observed; boresight "
                     f"error {r['boresight_error_arcsec']:.1f} arcsec; "
                     f"{r['method_ms']:.2f} ms")
        true_q = [r[f"true_q{c}"] for c in "wxyz"]
        solved_q = [r[f"solved_q{c}"] for c in "wxyz"]
        lines.append("  true quaternion [w, x, y, z]:   "
                     + ", ".join(f"{v:+.9f}" for v in true_q))
        if r["solved"]:
            lines.append("  solved quaternion [w, x, y, z]: "
                         + ", ".join(f"{v:+.9f}" for v in solved_q))
    return "\n".join(lines)

__all__ = [
    "LIBRARIES", "MAX_LISTED", "NOT_REPLAYED", "REPORT_FILE", "command_line", "failures",
    "provenance", "replay_text", "summary_table", "write_report",
]
