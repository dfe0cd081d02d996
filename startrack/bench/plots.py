"""Plots of a comparison (PNG, matplotlib's Agg backend, no display needed).

Per swept variable: correct rate and wrong rate with Wilson 95% intervals, median time on
a log axis with the p95 as the upper bar, and the attitude error (median, p95) of the
correct solutions. Methods are drawn with their own markers and a small sideways offset
so equal values do not hide each other. A ``--grid full`` run also gets a heat map of the
correct rate over the first two swept variables, one panel per method.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from startrack.bench.conditions import VARIABLES, Condition, sweep
from startrack.outputs import atomic_path

LABELS = {
    "noise_px": "centroid noise (px, 1 sigma)",
    "false_stars": "false stars per frame",
    "missing": "fraction of stars missing",
    "mag_noise": "magnitude noise (mag, 1 sigma)",
    "fov_error": "FOV error told to the method (fraction)",
    "distortion_k1": "lens distortion k1, not modelled",
    "modelled_k1": "lens distortion k1, modelled",
}
MARKERS = ("o", "s", "^", "D", "v", "P", "X", "*")


def wilson(successes, trials, z: float = 1.96) -> tuple[np.ndarray, np.ndarray]:
    """Wilson score interval (low, high) of a binomial rate; NaN where trials is 0."""
    k = np.asarray(successes, dtype=np.float64)
    n = np.asarray(trials, dtype=np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        p = k / n
        denom = 1.0 + z * z / n
        centre = (p + z * z / (2 * n)) / denom
        half = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    return np.clip(centre - half, 0.0, 1.0), np.clip(centre + half, 0.0, 1.0)


def _save(fig, path: Path) -> Path:
    import matplotlib.pyplot as plt

    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=100, format="png")
    plt.close(fig)
    return path


def _offsets(values: np.ndarray, n_methods: int) -> np.ndarray:
    """Sideways shift per method: 1.5% of the axis span, centred on the true value."""
    span = float(np.ptp(values)) or 1.0
    return (np.arange(n_methods) - (n_methods - 1) / 2.0) * 0.015 * span


def _rate_panel(ax, rows: pd.DataFrame, x: np.ndarray, column: str, count: str, style):
    k = rows[count].to_numpy(dtype=float)
    n = rows["frames"].to_numpy(dtype=float)
    low, high = wilson(k, n)
    y = rows[column].to_numpy(dtype=float)
    # the interval holds the rate, but rounding can put an end a hair inside it at 0 or 1
    ax.errorbar(x, y, yerr=[np.maximum(y - low, 0.0), np.maximum(high - y, 0.0)], capsize=3,
                **style)


def _sweep_figure(part: pd.DataFrame, var: str, methods: list[str]):
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 4, figsize=(16, 3.9))
    fig.subplots_adjust(left=0.04, right=0.99, bottom=0.15, top=0.84, wspace=0.25)
    values = np.sort(part[var].unique().astype(float))
    shift = _offsets(values, len(methods))
    for j, method in enumerate(methods):
        rows = part[part["method"] == method].sort_values(var)
        x = rows[var].to_numpy(dtype=float) + shift[j]
        style = dict(marker=MARKERS[j % len(MARKERS)], label=method, linewidth=1.2,
                     markersize=5, alpha=0.9)
        _rate_panel(axes[0], rows, x, "correct_rate", "correct", style)
        _rate_panel(axes[1], rows, x, "wrong_rate", "wrong", style)
        med = rows["time_median_ms"].to_numpy(dtype=float)
        p95 = rows["time_p95_ms"].to_numpy(dtype=float)
        axes[2].errorbar(x, med, yerr=[np.zeros_like(med), p95 - med], capsize=3, **style)
        err = rows["error_median_arcsec"].to_numpy(dtype=float)
        e95 = rows["error_p95_arcsec"].to_numpy(dtype=float)
        axes[3].errorbar(x, err, yerr=[np.zeros_like(err), np.nan_to_num(e95 - err)],
                         capsize=3, **style)
    titles = ("correct rate (95% Wilson interval)", "wrong rate (95% Wilson interval)",
              "identify time, ms (median, bar to p95)",
              "rotation error of correct solutions, arcsec (median-p95)")
    for ax, title in zip(axes, titles, strict=True):
        ax.set_xlabel(LABELS[var])
        ax.set_title(title, fontsize=9)
        ax.grid(True, alpha=0.3, which="both")
    axes[0].set_ylim(-0.02, 1.02)
    _, wrong_high = wilson(part["wrong"], part["frames"])
    axes[1].set_ylim(-0.005, min(1.02, max(0.05, 1.1 * float(np.nanmax(wrong_high)))))
    axes[2].set_yscale("log")
    from matplotlib.ticker import FormatStrFormatter

    axes[2].yaxis.set_major_formatter(FormatStrFormatter("%g"))
    axes[3].set_ylim(bottom=0.0)
    axes[0].legend(fontsize=8)
    frames = int(part["frames"].iloc[0]) if len(part) else 0
    fig.suptitle(f"{LABELS[var]} sweep ({frames} frames per point; methods offset "
                 "sideways so they do not hide each other)")
    return fig


def _counts(summary: pd.DataFrame) -> pd.DataFrame:
    summary = summary.copy()
    summary["correct"] = np.rint(summary["correct_rate"] * summary["frames"]).astype(int)
    if "wrong" not in summary:
        summary["wrong"] = np.rint(summary["wrong_rate"] * summary["frames"]).astype(int)
    return summary


def plot_sweeps(summary: pd.DataFrame, conditions: list[Condition], methods: list[str],
                out: Path) -> list[Path]:
    """One PNG per variable that takes more than one value (``plot_<variable>.png``)
    and, for a full grid, ``heatmap_correct.png``."""
    import matplotlib

    matplotlib.use("Agg")

    summary = _counts(summary)
    written = []
    for var in VARIABLES:
        picked = sweep(conditions, var)
        if len(picked) < 2:
            continue
        part = summary[summary["condition"].isin(picked)]
        written.append(_save(_sweep_figure(part, var, methods), out / f"plot_{var}.png"))
    heat = plot_heatmap(summary, conditions, methods, out)
    if heat is not None:
        written.append(heat)
    return written


def _grid_variables(conditions: list[Condition]) -> list[str]:
    return [v for v in VARIABLES if len({getattr(c, v) for c in conditions}) > 1]


def plot_heatmap(summary: pd.DataFrame, conditions: list[Condition], methods: list[str],
                 out: Path) -> Path | None:
    """Correct rate over the first two varied variables (the others at their base
    value), one panel per method; None unless the grid has both combinations."""
    import matplotlib.pyplot as plt

    varied = _grid_variables(conditions)
    if len(varied) < 2:
        return None
    vx, vy = varied[:2]
    base = conditions[0]
    others = [v for v in VARIABLES if v not in (vx, vy)]
    keep = [k for k, c in enumerate(conditions)
            if all(getattr(c, v) == getattr(base, v) for v in others)]
    part = summary[summary["condition"].isin(keep)]
    xs = np.sort(part[vx].unique())
    ys = np.sort(part[vy].unique())
    if len(part) < len(xs) * len(ys) * len(methods):
        return None  # a one-at-a-time grid: no full table to draw
    fig, axes = plt.subplots(1, len(methods), figsize=(4.2 * len(methods) + 1, 3.8),
                             squeeze=False)
    for ax, method in zip(axes[0], methods, strict=True):
        table = part[part["method"] == method].pivot_table(
            index=vy, columns=vx, values="correct_rate").reindex(index=ys, columns=xs)
        image = ax.imshow(table.to_numpy(), origin="lower", vmin=0.0, vmax=1.0,
                          cmap="viridis", aspect="auto")
        for (i, j), value in np.ndenumerate(table.to_numpy()):
            ax.text(j, i, f"{value:.2f}", ha="center", va="center", fontsize=8,
                    color="white" if value < 0.6 else "black")
        ax.set_xticks(range(len(xs)), [f"{v:g}" for v in xs])
        ax.set_yticks(range(len(ys)), [f"{v:g}" for v in ys])
        ax.set_xlabel(LABELS[vx])
        ax.set_ylabel(LABELS[vy])
        ax.set_title(f"{method}: correct rate", fontsize=9)
    fig.colorbar(image, ax=axes[0].tolist(), shrink=0.9)
    return _save(fig, out / "heatmap_correct.png")
