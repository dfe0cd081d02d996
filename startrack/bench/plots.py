"""Plots of a comparison: correct rate, wrong rate and median time against each swept
variable, one line per method (PNG, matplotlib's Agg backend, no display needed)."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from startrack.bench.conditions import VARIABLES, Condition, sweep
from startrack.cache import atomic_path

LABELS = {
    "noise_px": "centroid noise (px, 1 sigma)",
    "false_stars": "false stars per frame",
    "missing": "fraction of stars missing",
    "mag_noise": "magnitude noise (mag, 1 sigma)",
    "fov_error": "FOV error told to the method (fraction)",
    "distortion_k1": "lens distortion k1, not modelled",
    "modelled_k1": "lens distortion k1, modelled",
}
PANELS = (
    ("correct_rate", "correct rate", (-0.02, 1.02)),
    ("wrong_rate", "wrong rate", None),
    ("time_median_ms", "median identify time (ms)", None),
)


def plot_sweeps(summary: pd.DataFrame, conditions: list[Condition], methods: list[str],
                out: Path) -> list[Path]:
    """One PNG per variable that takes more than one value: ``plot_<variable>.png``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    written = []
    for var in VARIABLES:
        picked = sweep(conditions, var)
        if len(picked) < 2:
            continue
        part = summary[summary["condition"].isin(picked)]
        fig, axes = plt.subplots(1, len(PANELS), figsize=(13, 3.8))
        fig.subplots_adjust(left=0.05, right=0.99, bottom=0.15, top=0.84, wspace=0.22)
        for ax, (column, title, ylim) in zip(axes, PANELS, strict=True):
            for method in methods:
                rows = part[part["method"] == method].sort_values(var)
                ax.plot(rows[var], rows[column], marker="o", label=method)
            ax.set_xlabel(LABELS[var])
            ax.set_title(title)
            ax.grid(True, alpha=0.3)
            if ylim is not None:
                ax.set_ylim(*ylim)
            elif column == "wrong_rate":  # keep a zero wrong rate visibly at the bottom
                ax.set_ylim(-0.002, max(0.05, 1.15 * float(part[column].max())))
            else:
                ax.set_ylim(bottom=0.0)
        axes[0].legend()
        frames = int(part["frames"].iloc[0]) if len(part) else 0
        fig.suptitle(f"{LABELS[var]} sweep ({frames} frames per point)")
        path = out / f"plot_{var}.png"
        with atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=100, format="png")
        plt.close(fig)
        written.append(path)
    return written
