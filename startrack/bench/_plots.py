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

from startrack.bench._conditions import VARIABLES, Condition, is_default, sweep
from startrack.bench._stats import wilson
from startrack.io import atomic_path

LABELS = {
    "noise_px": "centroid noise (px, 1 sigma)",
    "false_stars": "false stars per frame",
    "missing": "fraction of stars missing",
    "mag_noise": "magnitude noise (mag, 1 sigma)",
    "fov_error": "FOV error told to the method (fraction)",
    "distortion_k1": "lens distortion k1, not modelled",
    "modelled_k1": "lens distortion k1, modelled",
    "cosmic_rays": "cosmic rays (hits / cm^2 / s)",
    "stray_light": "stray light at the centre (e- / px / s)",
    "temperature_c": "detector temperature (C)",
    "colour_index": "star colour B-V (every star, through the band)",
}
SHORT = {"noise_px": "noise px", "false_stars": "false stars", "missing": "missing",
         "mag_noise": "mag noise", "fov_error": "FOV error", "distortion_k1": "k1 unmodelled",
         "modelled_k1": "k1 modelled", "cosmic_rays": "cosmic rays", "stray_light": "stray light",
         "temperature_c": "temperature C", "colour_index": "B-V"}
#: variables a plot names as held even at zero
ALWAYS_SHOWN = ("noise_px", "false_stars", "missing")
MARKERS = ("o", "s", "^", "D", "v", "P", "X", "*")
#: attitude errors below this are floating-point rounding of an exact solution (a
#: noise-free frame solves to ~1e-9 arcsec); plots draw them as 0 and say "exact"
ERROR_RESOLUTION_ARCSEC = 1e-3


def save_figure(fig, path: Path) -> Path:
    """Write ``fig`` to ``path`` as PNG (atomically) and close it."""
    import matplotlib.pyplot as plt

    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=100, format="png")
    plt.close(fig)
    return path


def offsets(values: np.ndarray, n_methods: int) -> np.ndarray:
    """Sideways shift per method: 1.5% of the axis span, centred on the true value."""
    span = float(np.ptp(values)) or 1.0
    return (np.arange(n_methods) - (n_methods - 1) / 2.0) * 0.015 * span


def method_style(j: int, method: str) -> dict:
    """How method number ``j`` is drawn in every rate plot (the compare report's and the
    papers' results): its own marker, a thin line, labelled by its name."""
    return dict(marker=MARKERS[j % len(MARKERS)], label=method, linewidth=1.2,
                markersize=5, alpha=0.9)


def rate_panel(ax, rows: pd.DataFrame, x: np.ndarray, column: str, count: str, style):
    """Draw ``rows[column]`` against ``x`` with its 95% Wilson interval from the counts
    ``rows[count]`` over ``rows["frames"]``."""
    k = rows[count].to_numpy(dtype=float)
    n = rows["frames"].to_numpy(dtype=float)
    low, high = wilson(k, n)
    y = rows[column].to_numpy(dtype=float)
    # the interval holds the rate, but rounding can put an end a hair inside it at 0 or 1
    ax.errorbar(x, y, yerr=[np.maximum(y - low, 0.0), np.maximum(high - y, 0.0)], capsize=3,
                **style)


def rate_limits(k, n, pad: float = 0.1) -> tuple[float, float]:
    """A rate axis's y-range from the data: every point and its 95% Wilson interval, with
    ``pad`` of the span around (at least 2 points of percentage), within [0, 1]. Rates of
    96-100% then fill the panel instead of a line flat against the top."""
    low, high = wilson(k, n)
    k, n = np.asarray(k, dtype=float), np.asarray(n, dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        values = np.concatenate([low, high, k / n])
    values = values[np.isfinite(values)]
    if not len(values):
        return 0.0, 1.0
    lo, hi = float(values.min()), float(values.max())
    margin = max(pad * (hi - lo), 0.02)
    return max(0.0, lo - margin) - 0.005, min(1.0, hi + margin) + 0.005


def floor_errors(values) -> np.ndarray:
    """Attitude errors with floating-point rounding (below :data:`ERROR_RESOLUTION_ARCSEC`)
    shown as 0: at zero noise an exact solution differs from the truth by ~1e-9 arcsec."""
    v = np.asarray(values, dtype=float)
    return np.where(v < ERROR_RESOLUTION_ARCSEC, 0.0, v)


def held_text(conditions: list[Condition], varied: tuple[str, ...]) -> str:
    """What a plot holds fixed: every other variable at its base value (those that are
    zero throughout are left out, except the three the bench always sets)."""
    base = conditions[0]
    parts = []
    for var in VARIABLES:
        if var in varied:
            continue
        values = {getattr(c, var) for c in conditions}
        if var in ALWAYS_SHOWN or any(not is_default(var, v) for v in values):
            parts.append(f"{SHORT[var]} {getattr(base, var):g}")
    return "held: " + ", ".join(parts) if parts else ""


def _sweep_figure(part: pd.DataFrame, var: str, methods: list[str], held: str):
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 4, figsize=(16, 4.2))
    fig.subplots_adjust(left=0.04, right=0.99, bottom=0.14, top=0.80, wspace=0.25)
    values = np.sort(part[var].unique().astype(float))
    shift = offsets(values, len(methods))
    for j, method in enumerate(methods):
        rows = part[part["method"] == method].sort_values(var)
        x = rows[var].to_numpy(dtype=float) + shift[j]
        style = method_style(j, method)
        rate_panel(axes[0], rows, x, "correct_rate", "correct", style)
        rate_panel(axes[1], rows, x, "wrong_rate", "wrong", style)
        med = rows["time_median_ms"].to_numpy(dtype=float)
        p95 = rows["time_p95_ms"].to_numpy(dtype=float)
        axes[2].errorbar(x, med, yerr=[np.zeros_like(med), p95 - med], capsize=3, **style)
        err = floor_errors(rows["error_median_arcsec"])
        e95 = floor_errors(rows["error_p95_arcsec"])
        axes[3].errorbar(x, err, yerr=[np.zeros_like(err), np.nan_to_num(e95 - err)],
                         capsize=3, **style)
    _format_axes(axes, part, var)
    axes[0].legend(fontsize=8)
    frames = int(part["frames"].iloc[0]) if len(part) else 0
    fig.suptitle(f"{LABELS[var]} sweep: {frames} frames per point; {held}\n"
                 "(methods offset sideways so they do not hide each other)", fontsize=11)
    return fig


def _format_axes(axes, part: pd.DataFrame, var: str) -> None:
    """Titles, labels and y ranges of a sweep's four panels (rates zoomed to the data,
    times on a log axis, errors floored at the rounding level)."""
    from matplotlib.ticker import (
        FormatStrFormatter,
        LogLocator,
        NullFormatter,
        ScalarFormatter,
    )

    titles = ("correct rate (95% Wilson interval)", "wrong rate (95% Wilson interval)",
              "identify time, ms (median, bar to p95)",
              "rotation error of correct solutions,\narcsec (median, bar to p95)")
    for ax, title in zip(axes, titles, strict=True):
        ax.set_xlabel(LABELS[var])
        ax.set_title(title, fontsize=9)
        ax.grid(True, alpha=0.3, which="both")
    axes[0].set_ylim(*rate_limits(part["correct"], part["frames"]))
    axes[1].set_ylim(*rate_limits(part["wrong"], part["frames"]))
    for ax in axes[:2]:
        ax.yaxis.set_major_formatter(percent_label)
    axes[2].set_yscale("log")
    axes[2].yaxis.set_major_formatter(FormatStrFormatter("%g"))
    times = part[["time_median_ms", "time_p95_ms"]].to_numpy(dtype=float)
    times = times[np.isfinite(times) & (times > 0)]
    if len(times) and times.max() < 10.0 * times.min():  # under a decade: label 2, 3, 5
        axes[2].yaxis.set_minor_formatter(FormatStrFormatter("%g"))
        axes[2].tick_params(axis="y", which="minor", labelsize=7)
    else:  # several decades: 1-2-5 labels; every minor label would pile up
        axes[2].yaxis.set_major_locator(LogLocator(base=10.0, subs=(1.0, 2.0, 5.0)))
        axes[2].yaxis.set_minor_formatter(NullFormatter())
    plain = ScalarFormatter(useOffset=False)
    plain.set_scientific(False)  # no exponent above the panel, where it hit the title
    axes[3].yaxis.set_major_formatter(plain)
    axes[3].set_ylim(bottom=0.0)
    e95_all = floor_errors(part["error_p95_arcsec"])
    if np.nanmax(e95_all, initial=0.0) == 0.0:
        axes[3].set_ylim(0.0, 1.0)
        axes[3].text(0.5, 0.5, f"exact: every error below {ERROR_RESOLUTION_ARCSEC:g} arcsec",
                     transform=axes[3].transAxes, ha="center", va="center", fontsize=9)


def percent_label(value, _position) -> str:
    """A rate axis tick as a percentage (matplotlib tick formatter)."""
    return f"{100 * value:.4g}%"


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
        held = held_text(conditions, (var,))
        written.append(save_figure(_sweep_figure(part, var, methods, held),
                             out / f"plot_{var}.png"))
    heat = plot_heatmap(summary, conditions, methods, out)
    if heat is not None:
        written.append(heat)
    return written


def _grid_variables(conditions: list[Condition]) -> list[str]:
    return [v for v in VARIABLES if len({getattr(c, v) for c in conditions}) > 1]


def plot_heatmap(summary: pd.DataFrame, conditions: list[Condition], methods: list[str],
                 out: Path) -> Path | None:
    """Correct rate over the first two varied variables (the others at their base
    value, named in the title), one panel per method; None unless the grid has every
    combination. The colour scale runs from the lowest rate shown, so 88% and 100% differ.
    """
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
    lowest = float(part["correct_rate"].min())
    vmin = 0.0 if lowest < 0.5 else np.floor(lowest * 20.0) / 20.0 - 0.05
    fig, axes = plt.subplots(1, len(methods), figsize=(3.3 * len(methods) + 1.2, 3.9),
                             squeeze=False, layout="constrained")
    for ax, method in zip(axes[0], methods, strict=True):
        table = part[part["method"] == method].pivot_table(
            index=vy, columns=vx, values="correct_rate").reindex(index=ys, columns=xs)
        image = ax.imshow(table.to_numpy(), origin="lower", vmin=vmin, vmax=1.0,
                          cmap="viridis", aspect="auto")
        for (i, j), value in np.ndenumerate(table.to_numpy()):
            ax.text(j, i, f"{100 * value:.1f}%", ha="center", va="center", fontsize=8,
                    color="white" if value < vmin + 0.6 * (1.0 - vmin) else "black")
        ax.set_xticks(range(len(xs)), [f"{v:g}" for v in xs])
        ax.set_yticks(range(len(ys)), [f"{v:g}" for v in ys])
        ax.set_xlabel(SHORT[vx])
        ax.set_ylabel(SHORT[vy])
        ax.set_title(method, fontsize=10)
    fig.colorbar(image, ax=axes[0].tolist(), shrink=0.9, label="correct rate",
                 format=percent_label)
    frames = int(part["frames"].iloc[0])
    fig.suptitle(f"correct rate over {SHORT[vx]} x {SHORT[vy]}: {frames} frames per cell; "
                 f"{held_text(conditions, (vx, vy))}", fontsize=10)
    return save_figure(fig, out / "heatmap_correct.png")

__all__ = [
    "ALWAYS_SHOWN", "ERROR_RESOLUTION_ARCSEC", "LABELS", "MARKERS", "SHORT", "floor_errors",
    "held_text", "method_style", "offsets", "percent_label", "plot_heatmap", "plot_sweeps",
    "rate_limits", "rate_panel", "save_figure",
]
