"""`compare --mode tracking` and the tracking bench's outputs: tables, plots, report.md.

The conditions sweep one variable at a time around the base (the first value of each
list): the issue's sequence, (1, 0.5, 2) deg/s at 10 fps, 0.5 px noise, 2 false stars and
10% of the stars missing per frame.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import pandas as pd

from startrack.bench._conditions import parse_values
from startrack.bench._report_run import first_frame_lines, load_text, machine_load
from startrack.bench._tracking_bench import (
    VARIABLES,
    TrackCondition,
    is_tracking_method,
    oat_conditions,
    peer_available,
    run_tracking_bench,
)
from startrack.camera import Camera
from startrack.errors import InputError
from startrack.io import atomic_path, atomic_text
from startrack.sky import SkySpec, load_sky

BASE_RATE = f"{float(np.linalg.norm([1.0, 0.5, 2.0])):.4f}"
DEFAULT_LEVELS = {"rate_dps": f"{BASE_RATE},0,1,5,10", "noise_px": "0.5,0.25,1,2",
                  "false_stars": "2,0,5,10", "missing": "0.1,0,0.3"}
TRACKING_FRAMES = 100
LABELS = {"rate_dps": "rate (deg/s, along (1, 0.5, 2))", "noise_px": "centroid noise (px)",
          "false_stars": "false stars per frame", "missing": "fraction of stars missing"}
COLUMNS = {"method": "method", "rate_dps": "rate deg/s", "noise_px": "noise px",
           "false_stars": "false", "missing": "missing", "frames": "frames",
           "solved_rate": "solved", "tracked_rate": "tracked", "wrong": "wrong",
           "losses": "losses", "reacquire_frames_mean": "reacquire (frames)",
           "boresight_median_arcsec": "boresight err (\")", "roll_median_arcsec": "roll err (\")",
           "time_median_ms": "median ms/frame"}


def parse_tracking_levels(text: dict[str, str | None]) -> dict[str, tuple]:
    """Each variable's values (comma-separated text, None: the default)."""
    given = {k: DEFAULT_LEVELS[k] if text.get(k) is None else text[k] for k in VARIABLES}
    return {"rate_dps": parse_values(given["rate_dps"], "--rates"),
            "noise_px": parse_values(given["noise_px"], "--noise-px"),
            "false_stars": parse_values(given["false_stars"], "--false-stars", integer=True),
            "missing": parse_values(given["missing"], "--missing", high=1.0)}


def markdown_table(summary: pd.DataFrame) -> str:
    """The summary as a Markdown table (the columns of :data:`COLUMNS`)."""
    cols = [c for c in COLUMNS if c in summary]
    lines = ["| " + " | ".join(COLUMNS[c] for c in cols) + " |",
             "|" + "---|" * len(cols)]
    for _, row in summary.iterrows():
        lines.append("| " + " | ".join(_cell(c, row[c]) for c in cols) + " |")
    return "\n".join(lines)


def _cell(column: str, value) -> str:
    if isinstance(value, str):
        return value
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-"
    if column in ("solved_rate", "tracked_rate"):
        return f"{100 * value:.1f}%"
    if column in ("frames", "wrong", "losses", "false_stars"):
        return f"{int(value)}"
    return f"{value:.3g}" if column != "rate_dps" else f"{value:.2f}"


def lost_in_space_name(method: str) -> str | None:
    """The lost-in-space row a tracking method is compared with (ours ``X+track`` with
    ``X``, the peer's ``tetra3rs+hint`` with ``tetra3rs``); None for the others."""
    for suffix in ("+track", "+hint"):
        if method.endswith(suffix):
            return method[:-len(suffix)]
    return None


def time_ratios(summary: pd.DataFrame) -> pd.DataFrame:
    """Per condition and matcher: lost-in-space median time over tracking's, on the same
    frames (higher is better for tracking)."""
    rows = []
    for _, g in summary.groupby("condition", sort=False):
        times = dict(zip(g["method"], g["time_median_ms"], strict=True))
        for name, ms in times.items():
            alone = lost_in_space_name(name)
            if alone in times:
                rows.append({"condition": int(g["condition"].iloc[0]),
                             **{v: g[v].iloc[0] for v in VARIABLES}, "method": name,
                             "tracking_ms": ms, "lost_in_space_ms": times[alone],
                             "speed_up": times[alone] / ms})
    return pd.DataFrame(rows)


def plot_sweeps(summary: pd.DataFrame, conditions: list[TrackCondition], out: Path,
                prefix: str = "tracking") -> list[Path]:
    """One PNG per swept variable: tracked rate, median time and boresight error."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = (("tracked_rate", "frames solved by tracking", False),
              ("time_median_ms", "median identify time per frame (ms)", True),
              ("boresight_median_arcsec", "median boresight error (arcsec)", False))
    base = conditions[0]
    colour = {m: f"C{k}" for k, m in enumerate(dict.fromkeys(summary["method"]))}
    written = []
    for var in VARIABLES:
        picked = [k for k, c in enumerate(conditions) if all(
            getattr(c, v) == getattr(base, v) for v in VARIABLES if v != var)]
        if len({getattr(conditions[k], var) for k in picked}) < 2:
            continue
        part = summary[summary["condition"].isin(picked)]
        fig, axes = plt.subplots(1, 3, figsize=(13, 3.8))
        fig.subplots_adjust(left=0.05, right=0.99, bottom=0.15, top=0.84, wspace=0.25)
        for ax, (column, title, log) in zip(axes, panels, strict=True):
            for method, rows in part.groupby("method", sort=False):
                if column == "tracked_rate" and not is_tracking_method(str(method)):
                    continue
                rows = rows.sort_values(var)
                tracked = is_tracking_method(str(method))  # drawn over its reference
                ax.plot(rows[var], rows[column], marker="o" if tracked else "s",
                        ls="-" if tracked else "--", ms=6 if tracked else 8,
                        mfc="none" if not tracked else None, label=method,
                        color=colour[method], zorder=3 if tracked else 2)
            ax.set_xlabel(LABELS[var])
            ax.set_title(title)
            ax.grid(True, alpha=0.3)
            if log:
                ax.set_yscale("log")
        axes[1].legend(fontsize=8)
        held = ", ".join(f"{COLUMNS[v]} {getattr(base, v):g}" for v in VARIABLES if v != var)
        fig.suptitle(f"tracking: {LABELS[var]} sweep: {int(part['frames'].iloc[0])} frames "
                     f"per sequence; held: {held}")
        path = out / f"{prefix}_{var}.png"
        with atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=100, format="png")
        plt.close(fig)
        written.append(path)
    return written


def compare_tracking(camera: Camera, sky: SkySpec, *, methods: tuple[str, ...],
                     levels: dict[str, tuple], frames: int, fps: float, seed: int,
                     out: Path, threshold_arcsec: float = 60.0, with_peer: bool | None = None,
                     progress=None) -> tuple[pd.DataFrame, str]:
    """Run the tracking comparison and write frames.csv, summary.csv, report.md and the
    sweep plots into ``out``; returns the summary and the report's Markdown."""
    if frames < 2:
        raise InputError(f"--frames must be >= 2 for a sequence, got {frames}")
    if not (math.isfinite(fps) and fps > 0):
        raise InputError(f"--fps must be > 0, got {fps}")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    load_at_start = machine_load()
    catalog = load_sky(sky, camera)
    conditions = oat_conditions(levels)
    peer = peer_available() if with_peer is None else with_peer
    per_frame, summary = run_tracking_bench(catalog, camera, conditions, methods, frames,
                                            fps, seed, peer, threshold_arcsec, progress)
    for name, df in (("frames.csv", per_frame), ("summary.csv", summary),
                     ("time_ratio.csv", time_ratios(summary))):
        with atomic_text(out / name) as fh:
            df.to_csv(fh, index=False)
    plots = plot_sweeps(summary, conditions, out)
    report = "\n".join([
        f"# Tracking comparison ({frames} frames per sequence at {fps:g} fps, seed {seed})",
        "", f"Methods: {', '.join(dict.fromkeys(summary['method']))}"
        + ("" if peer else " (tetra3rs not installed here)"), "",
        markdown_table(summary), "", "Lost-in-space time over tracking time, same frames:", "",
        markdown_table_ratio(time_ratios(summary)), "", WARM_UP, "",
        *first_frame_lines(per_frame), "",
        f"Machine: {os.cpu_count()} CPU core(s); load average (1 / 5 / 15 min) "
        f"{load_text(load_at_start)} at the start, {load_text(machine_load())} at the end.",
        "", *[f"![{p.stem}]({p.name})" for p in plots], ""])
    with atomic_text(out / "report.md") as fh:
        fh.write(report)
    return summary, report


#: what is warm in a tracking run, and what is not (report.md says it)
WARM_UP = (
    "Warm-up: each method's lost-in-space matcher solves a throwaway frame before the first "
    "timed frame; the tracking step's first use and the tetra3rs peer are not warmed, so "
    "the first tracked frame (frame 1 of condition 0) may hold a one-time cost; every "
    "frame's time is in frames.csv. The check below is on each method's first timed frame.")


def markdown_table_ratio(ratios: pd.DataFrame) -> str:
    if ratios.empty:
        return "(no tracked method with its lost-in-space reference)"
    lines = ["| method | rate deg/s | noise px | false | missing | tracking ms | "
             "lost-in-space ms | speed-up |", "|---|---|---|---|---|---|---|---|"]
    for _, r in ratios.iterrows():
        lines.append(f"| {r['method']} | {r['rate_dps']:.2f} | {r['noise_px']:g} | "
                     f"{int(r['false_stars'])} | {r['missing']:g} | {r['tracking_ms']:.3g} | "
                     f"{r['lost_in_space_ms']:.3g} | {r['speed_up']:.1f}x |")
    return "\n".join(lines)


LOCK_ROWS = ("acquired", "tracking", "reacquired", "lost", "none")


def plot_timeline(per_frame: pd.DataFrame, path: Path, title: str) -> Path:
    """One sequence frame by frame: identify time (log) and each tracking method's lock
    state (our states; tetra3rs's derived from its mode in the same way)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (top, low) = plt.subplots(2, 1, figsize=(12, 6), sharex=True,
                                   gridspec_kw={"height_ratios": [3, 2]})
    fig.subplots_adjust(left=0.09, right=0.99, bottom=0.09, top=0.92, hspace=0.08)
    methods = list(dict.fromkeys(per_frame["method"]))
    colour = {m: f"C{k}" for k, m in enumerate(methods)}
    for method in methods:
        g = per_frame[per_frame["method"] == method].sort_values("frame")
        top.plot(g["frame"], g["method_ms"], marker=".", lw=0.8, label=method,
                 color=colour[method])
    top.set_yscale("log")
    top.set_ylabel("identify time (ms)")
    top.grid(True, alpha=0.3)
    top.legend(fontsize=8)
    tracked = [m for m in methods if is_tracking_method(m)]
    for k, method in enumerate(tracked):
        g = per_frame[per_frame["method"] == method].sort_values("frame")
        states = lock_states(g["solved"].to_numpy(bool), (g["mode"] == "tracking").to_numpy())
        ys = [LOCK_ROWS.index(s) + 0.15 * (k - (len(tracked) - 1) / 2) for s in states]
        low.scatter(g["frame"], ys, s=12, label=method, color=colour[method])
    low.set_yticks(range(len(LOCK_ROWS)), LOCK_ROWS)
    low.set_ylabel("lock")
    low.set_xlabel("frame")
    low.grid(True, alpha=0.3)
    fig.suptitle(title)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=100, format="png")
    plt.close(fig)
    return path


def lock_states(solved: np.ndarray, tracked: np.ndarray) -> list[str]:
    """Per frame the lock state (startrack.tracking._lock_state.LOCK_STATES) of a solved/tracked
    run."""
    states, locked, ever = [], False, False
    for ok, trk in zip(solved, tracked, strict=True):
        if ok:
            states.append("tracking" if trk else "reacquired" if ever else "acquired")
        else:
            states.append("lost" if locked else "none")
        locked, ever = bool(ok), ever or bool(ok)
    return states

__all__ = [
    "BASE_RATE", "COLUMNS", "TRACKING_FRAMES", "DEFAULT_LEVELS", "LABELS", "LOCK_ROWS",
    "compare_tracking", "lock_states", "lost_in_space_name", "markdown_table",
    "markdown_table_ratio", "parse_tracking_levels", "plot_sweeps", "plot_timeline", "time_ratios",
]
