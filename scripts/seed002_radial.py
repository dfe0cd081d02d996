"""Seed 002's comparison: misidentifications of the plain triangle matcher against radial
features + triangles, on its camera (4 x 4 deg, 4096 x 4096, 9 um; Hipparcos Hp <= 8).

Two measurements on the same deterministic frames (startrack.bench.frames):

1. verified (the bench, ``run_comparison``): wrong solutions and per-star wrong identities
   after the shared verification, which refuses most wrong hypotheses for every method;
2. raw (startrack.bench.raw): each matcher's first hypothesis, unverified, scored against
   the truth (right? how many wrong identities? a catalog star given to two observed
   stars, the paper's typical triangle error?), and how many wrong hypotheses come before
   the first right one among the first ``--limit``. This is what the paper compares.

    .venv/bin/python scripts/seed002_radial.py                # ~4 min on 2 cores
    .venv/bin/python scripts/seed002_radial.py --frames 100 --raw-frames 50   # quick look

Writes out/seed002_radial/ (bench/, raw.csv, table.csv) and docs/figures/seed002_radial_*.png,
and prints the tables.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import pandas as pd

from startrack.bench.conditions import build_conditions, sweep
from startrack.bench.raw import raw_pass, summarise_raw
from startrack.bench.runner import RunSpec
from startrack.bench.session import format_table, run_comparison
from startrack.config import load_config

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "configs" / "radial_triangles.toml"
METHODS = ("triangle", "radial")
LEVELS = {"noise_px": (0.3, 0.1, 1.0, 2.0), "false_stars": (0, 1, 2, 4),
          "missing": (0.0, 0.1), "mag_noise": (0.0,)}
KEYS = ["condition", "noise_px", "false_stars", "missing", "method"]


def make_spec(frames: int, max_stars: int) -> RunSpec:
    cfg = load_config(CONFIG)
    return RunSpec(methods=METHODS, conditions=tuple(build_conditions(LEVELS)),
                   frames=frames, seed=cfg.frames.seed, camera=cfg.camera, sky=cfg.sky,
                   max_stars=max_stars, hot_pixel_fraction=cfg.frames.hot_pixel_fraction)


def combine(summary: pd.DataFrame, raw: pd.DataFrame) -> pd.DataFrame:
    """Verified and raw figures side by side, one row per (condition, method)."""
    verified = summary[["condition", "method", "frames", "solved_rate", "correct_rate",
                        "wrong", "star_precision", "time_median_ms"]].copy()
    rs = summarise_raw(raw, KEYS).rename(columns={"frames": "raw_frames"})
    extra = raw.groupby(["condition", "method"], sort=False).agg(
        seq_ms_median=("seq_ms", "median"), cand_mean=("candidates", "mean"),
        hyps_mean=("hypotheses", "mean")).reset_index()
    return verified.merge(rs, on=["condition", "method"]).merge(
        extra, on=["condition", "method"])


def verified_star_errors(frames_csv: Path) -> pd.DataFrame:
    f = pd.read_csv(frames_csv)
    return f.groupby(["condition", "method"], sort=False)["n_id_wrong"].sum().rename(
        "verified_wrong_ids").reset_index()


def print_table(table: pd.DataFrame) -> None:
    show = pd.DataFrame({
        "noise": table["noise_px"].map("{:g}".format), "false": table["false_stars"],
        "miss": table["missing"].map("{:g}".format), "method": table["method"],
        "n": table["frames"], "correct": table["correct_rate"].map("{:.1%}".format),
        "wrong": table["wrong"], "wrong_ids": table["verified_wrong_ids"],
        "raw_n": table["raw_frames"],
        "raw_none": table["none_rate"].map("{:.1%}".format),
        "raw1_right": table["first_right_rate"].map("{:.1%}".format),
        "raw1_wrong": table["first_wrong_frames"],
        "raw1_wrong_ids": table["wrong_ids"],
        "of_which_false": table["false_star_ids"],
        "dup": table["duplicates"],
        "wrong_before": table["wrong_before_mean"].map("{:.2f}".format),
        "t_seq_ms": table["seq_ms_median"].map("{:.1f}".format),
        "hyps": table["hyps_mean"].map("{:.2f}".format),
    })
    print(show.to_string(index=False))


def plot(table: pd.DataFrame, spec: RunSpec, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    conds = list(spec.conditions)
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.4))
    for ax, var, label in ((axes[0], "noise_px", "centroid noise (px, 1 sigma)"),
                           (axes[1], "false_stars", "false stars per frame")):
        part = table[table["condition"].isin(sweep(conds, var))]
        for m in spec.methods:
            r = part[part["method"] == m].sort_values(var)
            ax.plot(r[var], r["first_wrong_rate"], "x--", label=f"{m}: raw 1st hyp. wrong")
            ax.plot(r[var], r["wrong"] / r["frames"], "o-", color=ax.lines[-1].get_color(),
                    label=f"{m}: verified wrong")
        ax.set_xlabel(label)
        ax.set_ylabel("fraction of frames")
        ax.set_ylim(bottom=-0.01)
        ax.grid(True, alpha=0.3)
    axes[0].legend(fontsize=7)
    fig.suptitle("Seed 002 setup: 4 x 4 deg, 4096 px, Hipparcos Hp <= 8: misidentifications",
                 fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=1000, help="bench frames per condition")
    ap.add_argument("--raw-frames", type=int, default=500,
                    help="frames per condition of the raw (unverified) pass")
    ap.add_argument("--max-stars", type=int, default=8,
                    help="brightest stars a matcher may use for patterns")
    ap.add_argument("--limit", type=int, default=20, help="hypotheses looked at per frame")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--resume", action="store_true",
                    help="finish an interrupted bench run in --out instead of starting over")
    ap.add_argument("--out", type=Path, default=ROOT / "out" / "seed002_radial")
    ap.add_argument("--figures", type=Path, default=ROOT / "docs" / "figures")
    args = ap.parse_args(argv)

    spec = make_spec(args.frames, args.max_stars)
    t0 = time.perf_counter()
    result = run_comparison(spec, args.out / "bench", jobs=args.jobs,
                            resume=args.resume or False)
    print(format_table(result.summary))
    print(f"\nbench: {time.perf_counter() - t0:.0f} s wall ({args.jobs} jobs); load: "
          f"{', '.join(f'{k} {v:.2f} s' for k, v in result.load_seconds.items())}")

    t0 = time.perf_counter()
    raw = raw_pass(spec, args.raw_frames, limit=args.limit, repeats=1, jobs=args.jobs)
    raw.to_csv(args.out / "raw.csv", index=False, float_format="%.6g")
    table = combine(result.summary, raw).merge(verified_star_errors(result.frames_csv),
                                               on=["condition", "method"])
    table.to_csv(args.out / "table.csv", index=False, float_format="%.6g")
    print(f"\nraw pass: {min(args.raw_frames, args.frames)} frames per condition, first "
          f"{args.limit} hypotheses, {time.perf_counter() - t0:.0f} s\n")
    print_table(table)

    args.figures.mkdir(parents=True, exist_ok=True)
    plot(table, spec, args.figures / "seed002_radial_misid.png")
    print(f"\nwrote {args.out}/table.csv, raw.csv, bench/; figures in {args.figures}/")
    return 0


if __name__ == "__main__":
    sys.exit(main())
