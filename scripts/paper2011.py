"""Reproduce seed 000's experiment (Sedaghat, Toloei, Ghanbarpoor 2011): angle, planar
triangle and hybrid on a random 2000-star sky, patterns from the five brightest stars,
compared on time, accuracy and noise, and on false stars.

Three passes over the same deterministic frames (startrack.bench.frames):

1. the bench (``run_comparison``, ``--jobs`` processes): verified solutions, scored;
2. a sequential pass over the first ``--timing-frames`` frames of each condition: the
   fastest of ``--repeats`` identify() runs in this one process (timings on a shared
   machine are otherwise dominated by preemption), with each method's diagnostics;
3. in the same pass, each matcher's *unverified* first hypothesis scored against the
   truth (startrack.bench.raw): the accuracy a matcher has on its own, as in the paper.

    .venv/bin/python scripts/paper2011.py                 # ~3 min on 2 cores
    .venv/bin/python scripts/paper2011.py --frames 200 --timing-frames 50   # quick look

Writes out/paper2011/ (bench/ with frames.csv, summary.csv and plots; seq.csv;
table.csv) and docs/figures/paper2011_sweeps.png, and prints the table.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import pandas as pd

from startrack.bench.conditions import build_conditions, sweep
from startrack.bench.raw import raw_unit, summarise_raw
from startrack.bench.runner import RunSpec
from startrack.bench.session import format_table, run_comparison
from startrack.config import load_config

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "configs" / "paper2011.toml"
METHODS = ("angle", "triangle", "hybrid")
NOISE_PX = (0.0, 0.5, 1.0, 2.0, 3.0)
FALSE_STARS = (0, 1, 2, 3, 5)
KEYS = ["condition", "noise_px", "false_stars", "method"]


def make_spec(frames: int, methods=METHODS, noise=NOISE_PX, false=FALSE_STARS) -> RunSpec:
    cfg = load_config(CONFIG)
    levels = {"noise_px": tuple(noise), "false_stars": tuple(false), "missing": (0.0,),
              "mag_noise": (0.0,)}
    return RunSpec(methods=tuple(methods), conditions=tuple(build_conditions(levels)),
                   frames=frames, seed=cfg.frames.seed, camera=cfg.camera, sky=cfg.sky,
                   max_stars=5, hot_pixel_fraction=cfg.frames.hot_pixel_fraction)


def sequential_pass(spec: RunSpec, frames: int, repeats: int) -> pd.DataFrame:
    rows = []
    for c in range(len(spec.conditions)):
        for f in range(min(frames, spec.frames)):
            rows += raw_unit(spec, c, f, repeats=repeats)
    return pd.DataFrame(rows)


def combine(summary: pd.DataFrame, seq: pd.DataFrame) -> pd.DataFrame:
    """One row per (condition, method): bench rates, sequential timing and diagnostics,
    raw first-hypothesis accuracy; time ratios against the triangle method."""
    raw = summarise_raw(seq, KEYS)
    agg = seq.groupby(KEYS, sort=False).agg(
        seq_ms_median=("seq_ms", "median"), seq_ms_mean=("seq_ms", "mean"),
        cand_median=("candidates", "median"), pivots_mean=("pivots", "mean"),
        hyps_mean=("hypotheses", "mean"),
        top3_rate=("real_in_top", lambda s: float((s >= 3).mean())),
    ).reset_index()
    if "x_shortlist_mean" in seq:
        short = seq[seq["method"] == "hybrid"].groupby(KEYS, sort=False)[
            "x_shortlist_mean"].median().rename("shortlist_median").reset_index()
        agg = agg.merge(short, on=KEYS, how="left")
    bench = summary[["condition", "method", "frames", "solved_rate", "correct_rate", "wrong",
                     "star_precision", "boresight_median_arcsec", "time_median_ms"]]
    table = bench.merge(agg, on=["condition", "method"]).merge(
        raw[KEYS + ["first_right_rate", "first_wrong_rate", "none_rate", "wrong_ids",
                    "wrong_before_mean"]], on=KEYS)
    tri = table[table["method"] == "triangle"].set_index("condition")["seq_ms_median"]
    table["seq_vs_triangle"] = table["seq_ms_median"] / table["condition"].map(tri)
    return table


def print_table(table: pd.DataFrame) -> None:
    show = pd.DataFrame({
        "noise": table["noise_px"].map("{:g}".format), "false": table["false_stars"],
        "method": table["method"], "n": table["frames"],
        "correct": table["correct_rate"].map("{:.1%}".format), "wrong": table["wrong"],
        "raw1_right": table["first_right_rate"].map("{:.1%}".format),
        "raw1_wrong": table["first_wrong_rate"].map("{:.1%}".format),
        "bore\"": table["boresight_median_arcsec"].map("{:.1f}".format),
        "t_bench": table["time_median_ms"].map("{:.2f}".format),
        "t_seq": table["seq_ms_median"].map("{:.2f}".format),
        "t/tri": table["seq_vs_triangle"].map("{:.2f}".format),
        "cand": table["cand_median"].map("{:.0f}".format),
        "pivots": table["pivots_mean"].map("{:.2f}".format),
        "hyps": table["hyps_mean"].map("{:.2f}".format),
        ">=3real": table["top3_rate"].map("{:.1%}".format),
    })
    print(show.to_string(index=False))


def plot(table: pd.DataFrame, spec: RunSpec, path: Path, seq_frames: int) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    conds = list(spec.conditions)
    fig, axes = plt.subplots(2, 2, figsize=(9, 6.2))
    for col, var, label in ((0, "noise_px", "centroid noise (px, 1 sigma)"),
                            (1, "false_stars", "false stars per frame")):
        part = table[table["condition"].isin(sweep(conds, var))]
        for m in spec.methods:
            r = part[part["method"] == m].sort_values(var)
            axes[0, col].plot(r[var], r["correct_rate"], "o-", label=f"{m} verified")
            axes[0, col].plot(r[var], r["first_right_rate"], "x--",
                              color=axes[0, col].lines[-1].get_color(),
                              label=f"{m} raw 1st hyp.")
            axes[1, col].plot(r[var], r["seq_ms_median"], "o-", label=m)
        axes[0, col].set_ylim(-0.02, 1.02)
        axes[0, col].set_ylabel("correct rate")
        axes[1, col].set_ylabel("median identify time (ms)")
        axes[1, col].set_ylim(bottom=0)
        for ax in axes[:, col]:
            ax.set_xlabel(label)
            ax.grid(True, alpha=0.3)
    axes[0, 0].legend(fontsize=7)
    axes[1, 0].legend(fontsize=8)
    fig.suptitle(f"Seed 000 setup: random 2000-star sky, 17.5 deg, 5 brightest stars. "
                 f"Verified: {spec.frames} frames per point; raw 1st hypothesis and times "
                 f"(best of repeats, 1 process): first {seq_frames}", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=1000, help="bench frames per condition")
    ap.add_argument("--timing-frames", type=int, default=300,
                    help="frames per condition of the sequential timing/raw pass")
    ap.add_argument("--repeats", type=int, default=3, help="identify runs per timing")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--resume", action="store_true",
                    help="finish an interrupted bench run in --out instead of starting over")
    ap.add_argument("--out", type=Path, default=ROOT / "out" / "paper2011")
    ap.add_argument("--figures", type=Path, default=ROOT / "docs" / "figures")
    args = ap.parse_args(argv)

    spec = make_spec(args.frames)
    t0 = time.perf_counter()
    result = run_comparison(spec, args.out / "bench", jobs=args.jobs,
                            resume=args.resume or False)
    t_bench = time.perf_counter() - t0
    print(format_table(result.summary))
    print(f"\nbench: {t_bench:.0f} s wall ({args.jobs} jobs); "
          f"load: {', '.join(f'{k} {v:.2f} s' for k, v in result.load_seconds.items())}")

    t0 = time.perf_counter()
    seq = sequential_pass(spec, args.timing_frames, args.repeats)
    seq.to_csv(args.out / "seq.csv", index=False, float_format="%.6g")
    t_seq = time.perf_counter() - t0
    table = combine(result.summary, seq)
    table.to_csv(args.out / "table.csv", index=False, float_format="%.6g")
    print(f"\nsequential pass: {min(args.timing_frames, args.frames)} frames per condition, "
          f"best of {args.repeats} runs, {t_seq:.0f} s\n")
    print_table(table)

    args.figures.mkdir(parents=True, exist_ok=True)
    plot(table, spec, args.figures / "paper2011_sweeps.png",
         min(args.timing_frames, args.frames))
    print(f"\nwrote {args.out}/table.csv, seq.csv, bench/; figures in {args.figures}/")
    return 0


if __name__ == "__main__":
    sys.exit(main())
