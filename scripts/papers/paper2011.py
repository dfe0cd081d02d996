"""Re-run the experiment of "Automatic star identification using triangle base and increase
search speed" (Sedaghat, Toloei, Ghanbarpoor 2011): angle, planar triangle and hybrid on a
random 2000-star sky, patterns from the five brightest stars, judged claim by claim.

Four measurements on the same deterministic frames (startrack.bench._frames), every method
(ours and the paper's literal variants) on every frame:

1. verified (the bench, ``--frames`` per condition, ``--jobs`` processes): the answer
   ``identify()`` returns after the shared verification, over a noise x false-star grid;
2. raw (``--raw-frames`` per condition, ``--jobs`` processes): each matcher's first
   hypothesis, unverified, scored against the truth (the paper's accuracy), with its
   pivots and catalog candidates;
3. timing (``--timing-frames`` per condition of the two one-axis sweeps, in this one
   process): after ``--warmup`` untimed frames per method, the fastest of ``--repeats``
   identify() runs per frame, methods interleaved frame by frame; median and p95;
4. the bench at other field widths (``--fov``, ``--fov-frames``);
5. the false-star magnitude rule's sensitivity (``--faint-frames``): the bench again at
   noise 0 and 1 px x 1, 3, 5 false stars, each false star fainter than the fifth
   brightest real star (``false_mags="faint"``) instead of uniform over the stars in view.

Then every claim's paired tests (scripts/papers/_paper2011_claims.py). Saves the small tables
(table.csv, timing.csv, fov.csv, claims.csv) and run.json in docs/data/triangle-base-2011/,
the plot in docs/figures/paper2011_rates.png, and re-renders docs/results.md.

    .venv/bin/python scripts/papers/paper2011.py --jobs 2               # the full run
    .venv/bin/python scripts/papers/paper2011.py --frames 40 --raw-frames 20 --timing-frames 10 \\
        --fov-frames 20 --jobs 2                                  # a quick look
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

from scripts._cli import add_paper_passes, script_parser
from scripts.papers import _paper2011_claims as claims
from scripts.papers import _results_doc as results_doc
from startrack.bench import (
    RatePanel,
    RunSpec,
    bench_frame,
    build_conditions,
    load_bench,
    plot_rate_grid,
    raw_pass,
    run_comparison,
    timed_runs,
)
from startrack.simulate import load_config

ROOT = Path(__file__).resolve().parents[2]
CONFIG = ROOT / "configs" / "paper2011.toml"
SLUG = "triangle-base-2011"
METHODS = ("angle", "triangle", "hybrid")
# The paper-literal variants run beside ours (startrack/matchers: registered names).
VARIANTS = ("angle_closed", "angle_open", "triangle_nopivot", "triangle_first",
            "hybrid_nofourth", "hybrid_single")
PLOTTED = ("angle", "triangle", "hybrid", "angle_open", "triangle_first", "hybrid_single")
NOISE_PX = (0.0, 0.5, 1.0, 2.0, 3.0)
FALSE_STARS = (0, 1, 2, 3, 5)
GROUP = ["condition", "noise_px", "false_stars", "method"]


def make_spec(frames: int, methods=METHODS, noise=NOISE_PX, false=FALSE_STARS,
              grid: str = "full") -> RunSpec:
    cfg = load_config(CONFIG)
    levels = {"noise_px": tuple(noise), "false_stars": tuple(false), "missing": (0.0,),
              "mag_noise": (0.0,)}
    return RunSpec(methods=tuple(methods), conditions=tuple(build_conditions(levels, grid)),
                   frames=frames, seed=cfg.frames.seed, camera=cfg.camera, sky=cfg.sky,
                   max_stars=5, extra_stars=0,  # the paper's five brightest, no more
                   hot_pixel_fraction=cfg.frames.hot_pixel_fraction, grid=grid)


def raw_frames(spec: RunSpec, frames: int, jobs: int) -> pd.DataFrame:
    """The raw pass (first hypotheses unverified, diagnostics of one verified run) with
    each frame's catalog candidates per lookup (``kept_per_lookup``, ``area_per_lookup``)."""
    raw = raw_pass(spec, frames, repeats=1, jobs=jobs)
    raw["kept_per_lookup"] = claims.per_lookup(raw)
    lookups = raw["x_lookups"].where(raw["x_lookups"] > 0) if "x_lookups" in raw else np.nan
    raw["area_per_lookup"] = raw["candidates"] / lookups
    return raw


def timing_frames(spec: RunSpec, frames: int, repeats: int, warmup: int) -> pd.DataFrame:
    """The timing pass in this process: ``warmup`` untimed frames per method first, then
    per frame every method in turn, the fastest of ``repeats`` runs each."""
    bench = load_bench(spec)
    for f in range(warmup):
        _, _, bf = bench_frame(spec, 0, spec.frames + f)  # frames the timing never uses
        for name in spec.methods:
            bench.identifier(name, bf.obs.camera).identify(bf.obs)
    rows = []
    for c, cond in enumerate(spec.conditions):
        for f in range(min(frames, spec.frames)):
            _, _, bf = bench_frame(spec, c, f)
            for name in spec.methods:
                ident = bench.identifier(name, bf.obs.camera)
                timed = timed_runs(ident, bf.obs, repeats, bf.truth_rows)
                rows.append({"condition": c, **cond.to_dict(), "frame": f, "method": name,
                             "seq_ms": timed["seq_ms"], "matcher_ms": timed["matcher_ms"]})
    return pd.DataFrame(rows)


def _q95(s: pd.Series) -> float:
    return float(np.percentile(s, 95))


def timing_table(timing: pd.DataFrame) -> pd.DataFrame:
    """Median and p95 per (condition, method), and the median over triangle's."""
    t = timing.groupby(GROUP, sort=False).agg(
        frames=("seq_ms", "size"), seq_ms_median=("seq_ms", "median"),
        seq_ms_p95=("seq_ms", _q95), matcher_ms_median=("matcher_ms", "median"),
        matcher_ms_p95=("matcher_ms", _q95)).reset_index()
    tri = t[t["method"] == "triangle"].set_index("condition")["seq_ms_median"]
    t["vs_triangle"] = t["seq_ms_median"] / t["condition"].map(tri)
    return t


def summary_table(verified: pd.DataFrame, raw: pd.DataFrame) -> pd.DataFrame:
    """Counts per (condition, method): verified right and wrong over ``frames``; raw first
    hypothesis right, wrong and absent over ``raw_frames``; diagnostics."""
    v = verified.groupby(GROUP, sort=False).agg(
        frames=("correct", "size"), correct=("correct", "sum"), wrong=("wrong", "sum"),
        boresight_median_arcsec=("boresight_error_arcsec", "median")).reset_index()
    yielded, right = raw["yielded"].astype(bool), raw["first_right"].astype(bool)
    raw = raw.assign(first_wrong=yielded & ~right, none=~yielded, right=right,
                     real3=raw["real_in_top"] >= 3)
    r = raw.groupby(GROUP, sort=False).agg(
        raw_frames=("right", "size"), first_right=("right", "sum"),
        first_wrong=("first_wrong", "sum"), no_answer=("none", "sum"),
        top5=("top5_correct", "sum"), real3=("real3", "sum"),
        pivots_mean=("pivots", "mean"), hyps_mean=("hypotheses", "mean"),
        cand_median=("candidates", "median"), kept_per_lookup=("kept_per_lookup", "median"),
        area_per_lookup=("area_per_lookup", "median")).reset_index()
    return v.merge(r, on=GROUP, how="left")


def fov_runs(fovs, frames: int, jobs: int, out: Path) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The bench at other field widths (same sky, same 1024 px, five brightest stars,
    noise 0 and 1 px x 0 and 3 false stars): (summary per field, condition and method
    with the stars in view; the frames of the narrowest field)."""
    from startrack.camera import Camera

    tables, narrow = [], None
    for fov in fovs:
        spec = make_spec(frames, METHODS + ("angle_open", "triangle_first", "hybrid_single"),
                         noise=(0.0, 1.0), false=(0, 3))
        spec = dataclasses.replace(spec, camera=Camera.from_fov(1024, 1024, fov))
        res = run_comparison(spec, out / f"fov_{fov:g}", jobs=jobs, resume=False)
        f = pd.read_csv(res.frames_csv)
        view = f.groupby("condition")["n_true_in_view"]
        t = f.groupby(GROUP, sort=False).agg(frames=("correct", "size"),
                                             correct=("correct", "sum"),
                                             wrong=("wrong", "sum")).reset_index()
        t = t.assign(fov_deg=fov, view_mean=t["condition"].map(view.mean()),
                     view_min=t["condition"].map(view.min()),
                     view_max=t["condition"].map(view.max()))
        tables.append(t)
        if narrow is None or fov < narrow[0]:
            narrow = (fov, f)
    return pd.concat(tables, ignore_index=True), narrow[1]


def faint_run(frames: int, jobs: int, out: Path) -> pd.DataFrame:
    """The false-star rule's sensitivity: the same conditions under both rules (uniform,
    faint), verified counts per (rule, condition, method), and the frames whose five
    brightest spots hold at least 3 real stars."""
    methods = METHODS + ("angle_open", "triangle_first", "hybrid_single")
    tables = []
    for rule in ("uniform", "faint"):
        spec = dataclasses.replace(make_spec(frames, methods, noise=(0.0, 1.0),
                                             false=(1, 3, 5)), false_mags=rule)
        res = run_comparison(spec, out / f"false_{rule}", jobs=jobs, resume=False)
        f = pd.read_csv(res.frames_csv)
        t = f.groupby(GROUP, sort=False).agg(frames=("correct", "size"),
                                             correct=("correct", "sum"),
                                             wrong=("wrong", "sum")).reset_index()
        tables.append(t.assign(rule=rule))
    return pd.concat(tables, ignore_index=True)


def patch_reading(n_stars: int, fov_rad: float, view_mean: float) -> dict:
    """The "0.025 x 0.025" read as radians: stars in view on the whole sphere, and the
    patch that 2000 stars must fill for the field to hold ``view_mean`` stars."""
    whole_sky = n_stars * fov_rad**2 / (4 * np.pi)
    patch_sr = n_stars * fov_rad**2 / view_mean
    return {"fov_rad": fov_rad, "fov_deg": float(np.degrees(fov_rad)),
            "whole_sky_in_view": whole_sky, "view_mean": view_mean,
            "patch_side_deg": float(np.degrees(np.sqrt(patch_sr))),
            "patch_fraction_of_sky": patch_sr / (4 * np.pi)}


def plot(table: pd.DataFrame, path: Path, run: dict) -> Path:
    methods = [m for m in PLOTTED if m in set(table["method"])]
    return plot_rate_grid(
        table, methods,
        [RatePanel("verified and right", "correct", "frames"),
         RatePanel("first hypothesis right, unverified", "first_right", "raw_frames")],
        path, f"The 2011 paper's setup: random 2000-star sky, 17.5 deg, 5 brightest stars; "
              f"verified {run['frames']} frames, raw {run['raw_frames']} frames per point "
              f"(commit {run['git commit'][:12]})")


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    ap = script_parser(__doc__)
    add_paper_passes(ap, frames=1000, raw_frames=300, methods=",".join(METHODS + VARIANTS))
    ap.add_argument("--timing-frames", type=int, default=300,
                    help="frames per condition of the timing pass (one process)")
    ap.add_argument("--repeats", type=int, default=3, help="identify runs per timing")
    ap.add_argument("--warmup", type=int, default=20,
                    help="untimed frames per method before the timing pass")
    ap.add_argument("--fov", default="10,17.5,25",
                    help="field widths (deg) of the field-width runs ('' to skip)")
    ap.add_argument("--fov-frames", type=int, default=200,
                    help="bench frames per condition of the field-width runs")
    ap.add_argument("--faint-frames", type=int, default=200,
                    help="bench frames per condition of the false-star rule's sensitivity "
                         "run (0 to skip)")
    ap.add_argument("--reuse", action="store_true",
                    help="no measuring: the per-frame tables of the last run in --out, "
                         "stamped with that run's record (give the same sizes)")
    results_doc.add_run_args(ap, "paper2011", SLUG)
    return ap.parse_args(argv)


def measure(args, spec: RunSpec) -> dict[str, pd.DataFrame]:
    """The four measurements; returns the per-frame tables by name."""
    t0 = time.perf_counter()
    result = run_comparison(spec, args.out / "bench", jobs=args.jobs,
                            resume=args.resume or False)
    verified = pd.read_csv(result.frames_csv)
    print(f"verified: {time.perf_counter() - t0:.0f} s", flush=True)
    t0 = time.perf_counter()
    raw = raw_frames(spec, args.raw_frames, args.jobs)
    print(f"raw: {time.perf_counter() - t0:.0f} s", flush=True)
    t0 = time.perf_counter()
    oat = make_spec(args.frames, spec.methods, grid="oat")
    load = os.getloadavg()
    timing = timing_frames(oat, args.timing_frames, args.repeats, args.warmup)
    timing.attrs["load"] = [round(x, 2) for x in (*load, *os.getloadavg())]
    print(f"timing: {time.perf_counter() - t0:.0f} s", flush=True)
    t0 = time.perf_counter()
    fovs = [float(x) for x in args.fov.split(",") if x.strip()]
    fov, fov10 = fov_runs(fovs, args.fov_frames, args.jobs, args.out) if fovs else (
        pd.DataFrame(), pd.DataFrame(columns=verified.columns))
    print(f"field widths: {time.perf_counter() - t0:.0f} s", flush=True)
    t0 = time.perf_counter()
    faint = faint_run(args.faint_frames, args.jobs, args.out) if args.faint_frames \
        else pd.DataFrame()
    print(f"false-star rule: {time.perf_counter() - t0:.0f} s", flush=True)
    data = {"verified": verified, "raw": raw, "timing": timing, "fov": fov, "fov10": fov10,
            "faint": faint}
    for name, frame in data.items():  # the per-frame tables, for --reuse
        frame.to_csv(args.out / f"{name}_frames.csv", index=False)
    (args.out / "timing_load.json").write_text(json.dumps(timing.attrs["load"]))
    return data


def _read(path: Path) -> pd.DataFrame:
    """A saved per-frame table; an empty one for a pass that was skipped."""
    return pd.read_csv(path) if path.stat().st_size > 1 else pd.DataFrame()


def reuse(out: Path) -> dict[str, pd.DataFrame]:
    """The per-frame tables a previous run saved in ``out`` (``--reuse``)."""
    data = {name: _read(out / f"{name}_frames.csv")
            for name in ("verified", "raw", "timing", "fov", "fov10", "faint")}
    data["timing"].attrs["load"] = json.loads((out / "timing_load.json").read_text())
    return data


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    record = results_doc.run_record(argv, "scripts/papers/paper2011.py")
    t_start = time.perf_counter()
    spec = make_spec(args.frames, methods=tuple(args.methods.split(",")))
    if args.reuse:  # stamped with the run that measured the frames, not this one
        data = reuse(args.out)
        record = {**json.loads((args.out / "record.json").read_text()),
                  "re-rendered": {k: record[k] for k in ("command", "git commit",
                                                         "date (UTC)")}}
    else:
        (args.out).mkdir(parents=True, exist_ok=True)
        (args.out / "record.json").write_text(json.dumps(record))
        data = measure(args, spec)
    table = summary_table(data["verified"], data["raw"])
    timing = timing_table(data["timing"])
    claim_rows = claims.claims_table(data)
    view = data["verified"].query("condition == 0")["n_true_in_view"]
    extra = dict(frames=args.frames, raw_frames=min(args.raw_frames, args.frames),
                 timing_frames=min(args.timing_frames, args.frames), repeats=args.repeats,
                 warmup=args.warmup, fov_frames=args.fov_frames,
                 faint_frames=args.faint_frames, jobs=args.jobs,
                 timing_load=data["timing"].attrs["load"], cpus=os.cpu_count(),
                 view_mean=float(view.mean()), view_min=int(view.min()),
                 view_max=int(view.max()),
                 reading=patch_reading(spec.sky.n_stars, 0.025, float(view.mean())),
                 arcsec_per_px=float(np.degrees(1.0 / spec.camera.f_px) * 3600.0))
    figure = plot(table, args.figures / "paper2011_rates.png", {**record, **extra})
    results_doc.save_tables(args.data, record, {
        "table": table, "timing": timing, "fov": data["fov"], "claims": claim_rows,
        "false_rule": data["faint"]},
        wall_s=time.perf_counter() - t_start, figure=str(figure.relative_to(ROOT)), **extra)
    print(claim_rows[claim_rows["condition"] == "pooled"].to_string(index=False))
    print(f"\nwrote {args.data}/, {figure} and {results_doc.render()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
