"""The improved triangle paper's experiment ("An improved triangle star identification
algorithm with radial features"): radial features + triangles against the plain
side-side-side triangle method, on its camera (4 x 4 deg, 4096 x 4096, 9 um; Hipparcos
Hp <= 8), over a grid of centroid noise x false stars.

Three measurements on the same deterministic frames (startrack.bench._frames):

1. verified (the bench): the answer identify() returns after the shared verification;
2. raw (startrack.bench._raw): each matcher's first hypothesis, unverified;
3. labels (startrack.bench._misidentified): every star of the image identified, as the paper
   counts misidentified stars per image (its Figures 5 and 6).

Then the paper's Tables 2 to 4 (scripts/papers/_radial_tables.py), the paired tests and the
verdicts. Saves docs/data/radial-features/ (the section's small tables and run.json),
docs/figures/radial_features_misid.png, and re-renders docs/results.md.

    .venv/bin/python scripts/papers/radial_features.py --jobs 2                 # the full run
    .venv/bin/python scripts/papers/radial_features.py --frames 20 --raw-frames 10 \\
        --label-frames 10 --jobs 2                                     # a quick look
"""

from __future__ import annotations

import resource
import sys
import time
from dataclasses import replace
from pathlib import Path

import pandas as pd

from scripts._cli import add_paper_passes, script_parser
from scripts.papers import _radial_plot, _radial_tables
from scripts.papers import _results_doc as results_doc
from scripts.papers._radial_paired import combine, label_summary, paired_tests
from startrack.bench import RunSpec, build_conditions, label_pass, raw_pass, run_comparison
from startrack.simulate import load_config

ROOT = Path(__file__).resolve().parents[2]
CONFIG = ROOT / "configs" / "radial_triangles.toml"
SLUG = "radial-features"
#: ours and the paper's baseline (lost in space), then the literal and known-patch variants
METHODS = ("triangle", "radial", "sss", "radial_noise", "radial_paper", "radial_patch",
           "radial_paper_patch", "sss_patch", "sss_paper_patch")
#: the radial family, whose every star can be labelled (the triangle matcher cannot; the
#: labels of `sss_paper_patch` are `sss_patch`'s: the labelling rule is equation 5 already)
LABEL_METHODS = ("radial", "sss", "radial_paper", "radial_patch", "radial_paper_patch",
                 "sss_patch")
#: noise x false stars, every combination (grid="full")
LEVELS = {"noise_px": (0.1, 0.3, 1.0, 2.0), "false_stars": (0, 1, 2, 4), "missing": (0.0,),
          "mag_noise": (0.0,)}


def make_spec(frames: int, max_stars: int, methods=METHODS) -> RunSpec:
    cfg = load_config(CONFIG)
    return RunSpec(methods=tuple(methods),
                   conditions=tuple(build_conditions(LEVELS, grid="full")),
                   frames=frames, seed=cfg.frames.seed, camera=cfg.camera, sky=cfg.sky,
                   max_stars=max_stars, hot_pixel_fraction=cfg.frames.hot_pixel_fraction)


def parse_args(argv):
    ap = script_parser(__doc__)
    add_paper_passes(ap, frames=1000, raw_frames=500, methods=",".join(METHODS))
    ap.add_argument("--label-frames", type=int, default=200,
                    help="frames per condition with every star labelled")
    ap.add_argument("--max-stars", type=int, default=8,
                    help="brightest stars a matcher may use for patterns")
    ap.add_argument("--limit", type=int, default=20, help="hypotheses looked at per frame")
    results_doc.add_run_args(ap, "radial_features", SLUG)
    return ap.parse_args(argv)


def cpu_seconds() -> float:
    """CPU time of this process and of its finished worker processes (user + system)."""
    own, kids = (resource.getrusage(who) for who in (resource.RUSAGE_SELF,
                                                     resource.RUSAGE_CHILDREN))
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def timed(label: str, seconds: dict, fn, *args, **kwargs):
    """Run one stage; ``seconds[label]`` gets its wall time and ``seconds[label + " cpu"]``
    its CPU time (workers included), to size a full run on another machine."""
    print(f"{label}: running", flush=True)
    t0, c0 = time.perf_counter(), cpu_seconds()
    out = fn(*args, **kwargs)
    seconds[label] = round(time.perf_counter() - t0, 1)
    seconds[f"{label} cpu"] = round(cpu_seconds() - c0, 1)
    print(f"{label}: {seconds[label]:.0f} s wall, {seconds[label + ' cpu']:.0f} s CPU",
          flush=True)
    return out


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    record = results_doc.run_record(argv, "scripts/papers/radial_features.py")
    t_start, seconds = time.perf_counter(), {}
    methods = tuple(args.methods.split(","))
    spec = make_spec(args.frames, args.max_stars, methods)
    result = timed("verified", seconds, run_comparison, spec, args.out / "bench",
                   jobs=args.jobs, resume=args.resume or False)
    raw = timed("raw", seconds, raw_pass, spec, args.raw_frames, limit=args.limit,
                repeats=1, jobs=args.jobs)
    label_spec = replace(spec, methods=tuple(m for m in methods if m in LABEL_METHODS))
    labels = timed("labels", seconds, label_pass, label_spec, args.label_frames,
                   jobs=args.jobs)
    frames = pd.read_csv(result.frames_csv)
    for name, table in (("raw", raw), ("labels", labels)):
        table.to_csv(args.out / f"{name}.csv", index=False, float_format="%.10g")
    summary = label_summary(labels)
    worst = labels["condition"] == _radial_plot.worst_condition(summary)
    tables = {"table": combine(result.summary, raw, frames), "labels": summary,
              "paired": paired_tests(frames, raw, labels),
              "label_images": labels[worst][["condition", "frame", "method", "stars",
                                             "identified", "misidentified", "duplicates"]],
              **timed("paper tables", seconds, _radial_tables.tables, spec)}
    print(results_doc.fmt_table(tables["labels"], _radial_plot.LABEL_COLUMNS))
    _radial_plot.misid_figure(tables["labels"], tables["label_images"],
                              args.figures / "radial_features_misid.png", record)
    view = frames.query("condition == 0")["n_true_in_view"]
    results_doc.save_tables(
        args.data, record, tables, wall_s=time.perf_counter() - t_start, seconds=seconds,
        frames=args.frames, raw_frames=min(args.raw_frames, args.frames),
        label_frames=min(args.label_frames, args.frames), limit=args.limit,
        max_stars=args.max_stars, jobs=args.jobs, view_mean=float(view.mean()),
        view_min=int(view.min()), view_max=int(view.max()))
    print(f"\nwrote {args.data}/ and {results_doc.render()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
