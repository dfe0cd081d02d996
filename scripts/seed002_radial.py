"""Seed 002's comparison: misidentifications of the plain triangle matcher against radial
features + triangles, on its camera (4 x 4 deg, 4096 x 4096, 9 um; Hipparcos Hp <= 8).

Two measurements on the same deterministic frames (startrack.bench.frames):

1. verified (the bench, ``run_comparison``): wrong solutions and per-star wrong identities
   after the shared verification, which refuses most wrong hypotheses for every method;
2. raw (startrack.bench.raw): each matcher's first hypothesis, unverified, scored against
   the truth (right? how many wrong identities? a catalog star given to two observed
   stars, the paper's typical triangle error?), and how many wrong hypotheses come before
   the first right one among the first ``--limit``. This is what the paper compares.

    .venv/bin/python scripts/seed002_radial.py                # the full run
    .venv/bin/python scripts/seed002_radial.py --frames 100 --raw-frames 50   # quick look

Writes out/seed002_radial/ (bench/, raw.csv, table.csv), docs/data/radial-features/
(table.csv and run.json, the saved tables the section is rendered from),
docs/figures/seed002_radial_misid.png and docs/results.md (scripts/_results_doc.py), and
prints the tables.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import _results_doc as results_doc
import pandas as pd
from _doc_seed002 import COLUMNS

from startrack.bench.conditions import build_conditions
from startrack.bench.raw import raw_pass, summarise_raw
from startrack.bench.runner import RunSpec
from startrack.bench.session import format_table, run_comparison
from startrack.simulate._config import load_config

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "configs" / "radial_triangles.toml"
METHODS = ("triangle", "radial")
# The paper-literal variants run beside ours (startrack/matchers/radial.py).
VARIANTS = ("radial_noise", "radial_paper", "radial_patch", "sss")
LEVELS = {"noise_px": (0.3, 0.1, 1.0, 2.0), "false_stars": (0, 1, 2, 4),
          "missing": (0.0, 0.1), "mag_noise": (0.0,)}
KEYS = ["condition", "noise_px", "false_stars", "missing", "method"]


def make_spec(frames: int, max_stars: int, methods=METHODS) -> RunSpec:
    cfg = load_config(CONFIG)
    return RunSpec(methods=tuple(methods), conditions=tuple(build_conditions(LEVELS)),
                   frames=frames, seed=cfg.frames.seed, camera=cfg.camera, sky=cfg.sky,
                   max_stars=max_stars, hot_pixel_fraction=cfg.frames.hot_pixel_fraction)


def combine(summary: pd.DataFrame, raw: pd.DataFrame) -> pd.DataFrame:
    """Verified and raw figures side by side, one row per (condition, method)."""
    verified = summary[["condition", "method", "frames", "solved_rate", "correct_rate",
                        "wrong", "star_precision", "time_median_ms"]].copy()
    rs = summarise_raw(raw, KEYS).rename(columns={"frames": "raw_frames"})
    extra = raw.groupby(["condition", "method"], sort=False).agg(
        seq_ms_median=("seq_ms", "median"), matcher_ms_median=("matcher_ms", "median"),
        cand_mean=("candidates", "mean"), cand_median=("candidates", "median"),
        hyps_mean=("hypotheses", "mean"), ids5_rate=("top5_ids_right", "mean"),
        top5_rate=("top5_correct", "mean")).reset_index()
    verified["wrong_rate"] = verified["wrong"] / verified["frames"]
    return verified.merge(rs, on=["condition", "method"]).merge(
        extra, on=["condition", "method"])


def verified_star_errors(frames_csv: Path) -> pd.DataFrame:
    f = pd.read_csv(frames_csv)
    return f.groupby(["condition", "method"], sort=False)["n_id_wrong"].sum().rename(
        "verified_wrong_ids").reset_index()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=1000, help="bench frames per condition")
    ap.add_argument("--raw-frames", type=int, default=500,
                    help="frames per condition of the raw (unverified) pass")
    ap.add_argument("--max-stars", type=int, default=8,
                    help="brightest stars a matcher may use for patterns")
    ap.add_argument("--limit", type=int, default=20, help="hypotheses looked at per frame")
    ap.add_argument("--methods", default=",".join(METHODS + VARIANTS),
                    help="comma-separated matcher names (variants included)")
    results_doc.add_run_args(ap, "seed002_radial", "radial-features")
    args = ap.parse_args(argv)

    record = results_doc.run_record(argv, "scripts/seed002_radial.py")
    t_start = time.perf_counter()
    spec = make_spec(args.frames, args.max_stars, tuple(args.methods.split(",")))
    result = run_comparison(spec, args.out / "bench", jobs=args.jobs,
                            resume=args.resume or False)
    print(format_table(result.summary))
    t0 = time.perf_counter()
    raw = raw_pass(spec, args.raw_frames, limit=args.limit, repeats=1, jobs=args.jobs)
    raw.to_csv(args.out / "raw.csv", index=False, float_format="%.6g")
    table = combine(result.summary, raw).merge(verified_star_errors(result.frames_csv),
                                               on=["condition", "method"])
    table.to_csv(args.out / "table.csv", index=False, float_format="%.6g")
    print(f"\nraw pass: {min(args.raw_frames, args.frames)} frames per condition, first "
          f"{args.limit} hypotheses, {time.perf_counter() - t0:.0f} s\n")
    print(results_doc.fmt_table(table, COLUMNS))
    results_doc.plot_sweeps(table, spec.conditions, spec.methods,
                [("fraction of frames", [("first_wrong_rate", "x--", "raw 1st hyp. wrong"),
                                         ("wrong_rate", "o-", "verified wrong")])],
                args.figures / "seed002_radial_misid.png",
                "Seed 002 setup: 4 x 4 deg, 4096 px, Hipparcos: misidentifications")
    view = pd.read_csv(result.frames_csv).query("condition == 0")["n_true_in_view"]
    results_doc.save_tables(args.data, record, {"table": table},
             wall_s=time.perf_counter() - t_start, frames=args.frames,
             raw_frames=min(args.raw_frames, args.frames), limit=args.limit,
             max_stars=args.max_stars, jobs=args.jobs, view_mean=float(view.mean()),
             view_min=int(view.min()), view_max=int(view.max()))
    print(f"\nwrote {args.out}/ and {results_doc.render()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
