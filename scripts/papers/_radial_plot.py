"""The radial-features paper's Figure 6 on our frames: misidentified stars per image for
radial features + triangles and the plain triangle method, every star identified, in the
compare report's plot style (startrack.bench._plots), stamped with command and commit."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from startrack.bench import LABELS, SHORT, method_style, offsets, save_figure

#: the label pass's printed columns (header, column, format)
LABEL_COLUMNS = [("noise", "noise_px", "{:g}"), ("false", "false_stars", None),
                 ("method", "method", None), ("images", "images", None),
                 ("stars", "stars", None), ("identified", "identified", None),
                 ("right", "right", None), ("misid", "misidentified", None),
                 ("misid/img", "misid_per_image", "{:.3f}"),
                 ("img_misid", "images_misid", None), ("false_lab", "false_labelled", None),
                 ("dup", "duplicates", None), ("t_ms", "label_ms_median", "{:.0f}")]
#: the figure's methods: the paper's pair lost in space, and inside a known patch
FIGURE_METHODS = ("sss", "radial", "sss_patch", "radial_patch", "radial_paper_patch")


def worst_condition(summary: pd.DataFrame, baseline: str = "sss") -> int:
    """The condition where the plain triangle method misidentifies the most stars (the
    first on a tie; the base condition when it misidentifies none): Figure 6's images."""
    rows = summary[summary["method"] == baseline]
    if rows.empty or rows["misidentified"].max() == 0:
        return int(summary["condition"].min())
    return int(rows.loc[rows["misidentified"].idxmax(), "condition"])


def _held(summary: pd.DataFrame, var: str, baseline: str = "sss") -> float:
    """The level of the other swept variable at which the baseline misidentifies most."""
    other = "false_stars" if var == "noise_px" else "noise_px"
    rows = summary[summary["method"] == baseline]
    if rows.empty:
        return float(summary[other].min())
    return float(rows.groupby(other)["misidentified"].sum().idxmax())


def _per_image(ax, images: pd.DataFrame, methods: list[str], where: str,
               shown: int = 40) -> None:
    """The paper's Figure 6: misidentified stars of each of the first ``shown`` images of
    one condition, one line per method."""
    for j, m in enumerate(methods):
        r = images[images["method"] == m].sort_values("frame").head(shown)
        ax.plot(r["frame"] + 1 + 0.08 * (j - len(methods) / 2), r["misidentified"],
                **method_style(j, m))
    ax.set_xlabel("image")
    ax.set_ylabel("misidentified stars")
    ax.set_title(f"per image, every star identified ({where})", fontsize=9)


def _sweep(ax, summary: pd.DataFrame, methods: list[str], var: str) -> None:
    """Mean misidentified stars per image along ``var`` (the other swept variable where
    the baseline misidentifies most), with a 95% normal interval of the mean."""
    other = "false_stars" if var == "noise_px" else "noise_px"
    held = _held(summary, var)
    part = summary[summary[other] == held]
    values = np.sort(part[var].unique().astype(float))
    shift = offsets(values, len(methods))
    for j, m in enumerate(methods):
        r = part[part["method"] == m].sort_values(var)
        half = 1.96 * r["misid_sd"] / np.sqrt(r["images"].clip(lower=1))
        ax.errorbar(r[var].to_numpy(float) + shift[j], r["misid_per_image"], yerr=half,
                    capsize=2, **method_style(j, m))
    ax.set_xlabel(LABELS[var])
    ax.set_ylabel("misidentified stars per image")
    ax.set_title(f"mean per image (95% interval), {SHORT[other]} {held:g}", fontsize=9)


def misid_figure(summary: pd.DataFrame, images: pd.DataFrame, path: Path,
                 record: dict) -> Path:
    """Three panels: per image at the base condition, and the mean against noise and
    against false stars; the footer names the command and commit that made it."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    methods = [m for m in FIGURE_METHODS if m in set(summary["method"])]
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8), layout="constrained")
    cond = summary[summary["condition"] == worst_condition(summary)].iloc[0]
    _per_image(axes[0], images, methods,
               f"noise {cond.noise_px:g} px, {int(cond.false_stars)} false stars")
    _sweep(axes[1], summary, methods, "noise_px")
    _sweep(axes[2], summary, methods, "false_stars")
    for ax in axes:
        ax.grid(True, alpha=0.3)
        ax.set_ylim(bottom=-0.05, top=max(ax.get_ylim()[1], 1.0))
    axes[0].legend(fontsize=7)
    commit = str(record.get("git commit", "?"))[:12]
    fig.suptitle("Radial features + triangles against plain side-side-side triangles: "
                 "misidentified stars (4 x 4 deg, 4096 px, Hipparcos Hp <= 8)", fontsize=9)
    fig.get_layout_engine().set(rect=(0, 0.05, 1, 0.95))
    fig.text(0.01, 0.01, f"{record.get('command', '?')} at commit {commit}, "
             f"{record.get('date (UTC)', '?')} UTC", fontsize=6)
    path.parent.mkdir(parents=True, exist_ok=True)
    return save_figure(fig, path)
