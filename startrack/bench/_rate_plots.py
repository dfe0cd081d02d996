"""Rate against centroid noise and against false stars, one line per method with its 95%
Wilson interval: the papers' plots, drawn in the compare report's style
(:mod:`startrack.bench._plots`: the same markers, sideways offsets and zoomed rate axes).

The input is a table with one row per (noise_px, false_stars, method) and, per panel, a
count column and a trials column; a noise x false-star grid gives both sweeps (noise at
no false star, false stars at no noise) from one table.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from startrack.bench._plots import (
    LABELS,
    method_style,
    offsets,
    percent_label,
    rate_limits,
    rate_panel,
    save_figure,
)

SWEEPS = ("noise_px", "false_stars")


@dataclass(frozen=True)
class RatePanel:
    """One row of panels: ``count`` successes over ``trials`` frames, titled ``title``."""

    title: str
    count: str
    trials: str


def sweep_rows(table: pd.DataFrame, var: str) -> pd.DataFrame:
    """The rows of ``table`` along one axis: every level of ``var`` with the other
    swept variable at its lowest level (no false star, or no noise)."""
    other = [v for v in SWEEPS if v != var][0]
    return table[table[other] == table[other].min()]


def plot_rate_grid(table: pd.DataFrame, methods: list[str], panels: list[RatePanel],
                   path: Path, title: str) -> Path:
    """One row per panel, one column per swept variable (noise, false stars); each rate
    with its 95% Wilson interval and a y-range zoomed to the data and intervals."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(panels), 2, figsize=(10, 3.2 * len(panels) + 0.6),
                             squeeze=False, layout="constrained")
    for col, var in enumerate(SWEEPS):
        part = sweep_rows(table, var)
        values = np.sort(part[var].unique().astype(float))
        shift = offsets(values, len(methods))
        for row, panel in enumerate(panels):
            ax = axes[row, col]
            for j, method in enumerate(methods):
                rows = part[part["method"] == method].sort_values(var)
                if rows.empty:
                    continue
                rows = rows.assign(frames=rows[panel.trials],
                                   rate=rows[panel.count] / rows[panel.trials])
                x = rows[var].to_numpy(dtype=float) + shift[j]
                rate_panel(ax, rows, x, "rate", panel.count, method_style(j, method))
            shown = part[part["method"].isin(methods)]
            ax.set_ylim(*rate_limits(shown[panel.count], shown[panel.trials]))
            ax.yaxis.set_major_formatter(percent_label)
            ax.set_xlabel(LABELS[var])
            ax.set_title(f"{panel.title} (95% Wilson interval)", fontsize=9)
            ax.grid(True, alpha=0.3)
    axes[0, 0].legend(fontsize=7)
    fig.suptitle(title + "\n(methods offset sideways so they do not hide each other)",
                 fontsize=9)
    path.parent.mkdir(parents=True, exist_ok=True)
    return save_figure(fig, path)

__all__ = ["RatePanel", "SWEEPS", "plot_rate_grid", "sweep_rows"]
