"""The radial-features paper's section of docs/results.md, from docs/data/radial-features/."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from _results_doc import fmt_table, run_block, saved_run, variant_lines

COLUMNS = [("noise", "noise_px", "{:g}"), ("false", "false_stars", None),
           ("miss", "missing", "{:g}"), ("method", "method", None), ("n", "frames", None),
           ("correct", "correct_rate", "{:.1%}"), ("wrong", "wrong", None),
           ("wrong_ids", "verified_wrong_ids", None), ("ids5", "ids5_rate", "{:.1%}"),
           ("raw_n", "raw_frames", None), ("raw_none", "none_rate", "{:.1%}"),
           ("raw1_right", "first_right_rate", "{:.1%}"),
           ("raw1_wrong", "first_wrong_frames", None), ("raw1_wrong_ids", "wrong_ids", None),
           ("of_which_false", "false_star_ids", None), ("dup", "duplicates", None),
           ("wrong_before", "wrong_before_mean", "{:.2f}"),
           ("t_seq_ms", "seq_ms_median", "{:.1f}"), ("t_match", "matcher_ms_median", "{:.1f}"),
           ("cand", "cand_median", "{:.0f}"), ("hyps", "hyps_mean", "{:.2f}")]
LEGEND = """\
Columns: `correct`, `wrong` (solutions) and `wrong_ids` (per-star wrong identities in
accepted solutions) over `n` verified frames; `ids5`: verified solutions scored on the five
brightest spots only; raw over `raw_n` frames: `raw_none` no hypothesis at all,
`raw1_right`, `raw1_wrong` (frames whose first hypothesis has a wrong identity),
`raw1_wrong_ids` (wrong identities in those first hypotheses), `of_which_false` (false
stars given a catalog identity), `dup` (first hypotheses giving one catalog star to two
observed stars), `wrong_before` (mean wrong hypotheses before the first right one);
`t_seq_ms` (median identify time in the raw pass, worker processes, one run), `t_match` the
part of it inside the matcher; `cand`: median database candidates per frame; `hyps` (mean
hypotheses verified).
"""
PARAMETERS = """\
* **What is compared.** The paper's baseline is the classic side-side-side triangle test
  over all catalog stars: `sss` here (the radial matcher with no prefilter, through the
  pair table). `triangle` is our planar-triangle matcher (area and polar moment on a
  k-vector table), a different method, so a difference between `triangle` and `radial`
  cannot be credited to the radial prefilter; the one between `sss` and `radial` can.
"""
VARIANTS = [("sss", "radial", "the radial prefilter on the plain side-side-side test: "
             "the paper's comparison"),
            ("triangle", "sss", "the paper's baseline against our planar triangles"),
            ("radial", "radial_noise", "ring width from each frame's stated noise"),
            ("radial", "radial_paper", "the paper's R and dr per frame"),
            ("radial", "radial_patch", "the paper's rings within a known sky patch")]


def _rings(run: dict) -> str:
    """Our fixed rings against the paper's per-frame ones, on the first base frames."""
    import seed002_radial

    from startrack.bench.runner import bench_frame, load_bench
    from startrack.matchers.radial import field_rings

    spec = seed002_radial.make_spec(run["frames"], run["max_stars"], ("radial",))
    m = load_bench(spec).identifiers["radial"].matcher
    frames = min(run["raw_frames"], 50)
    rings = np.array([field_rings(bench_frame(spec, 0, f)[2].obs.vectors)
                      for f in range(frames)])
    r_deg, dr_deg = np.degrees(np.median(rings, axis=0))
    count = np.ceil(rings[:, 0] / rings[:, 1])
    return (f"* **Rings.** `radial` uses R = {np.degrees(m.radius_rad):.2f} deg and a ring "
            f"width of {np.degrees(m.ring_width_rad) * 3600:.1f}\" "
            f"({m.table.n_rings} rings), set once from the catalog density and an assumed "
            f"noise; the paper's rule (R the largest, dr the smallest separation among the "
            f"field's stars) gives a median R of {r_deg:.2f} deg and dr of {dr_deg:.2f} deg "
            f"({np.median(count):.0f} rings, {count.min():.0f}-{count.max():.0f}) over the "
            f"first {frames} base frames (computed by scripts/_doc_seed002.py).\n")


def _totals(t: pd.DataFrame) -> pd.DataFrame:
    return t.groupby("method", sort=False)[["first_wrong_frames", "wrong_ids",
                                            "false_star_ids", "duplicates", "wrong",
                                            "verified_wrong_ids", "raw_frames"]].sum()


def _claims(t: pd.DataFrame) -> str:
    tot = _totals(t)
    raw = "; ".join(f"`{m}` {int(r.first_wrong_frames)} ({int(r.wrong_ids)} wrong "
                    f"identities, {int(r.false_star_ids)} of them false stars)"
                    for m, r in tot.iterrows())
    base = t[t["condition"] == 0].set_index("method")
    worst_noise = t[t["noise_px"] == t["noise_px"].max()].set_index("method")
    worst_false = t[t["false_stars"] == t["false_stars"].max()].set_index("method")

    def per(frame: pd.DataFrame, col: str, form: str) -> str:
        return ", ".join(f"`{m}` {form.format(v)}" for m, v in frame[col].items())

    dups = ", ".join(f"`{m}` {int(v)}" for m, v in tot["duplicates"].items())
    wrong = ", ".join(f"`{m}` {int(v)}" for m, v in tot["wrong"].items())
    return (f"* **Fewer misidentifications than the plain triangle method (raw).** Over "
            f"all conditions ({int(tot['raw_frames'].iloc[0])} raw frames per method) the "
            f"frames whose first hypothesis is wrong: {raw}.\n"
            f"* **How often each answers.** No hypothesis at all at the base condition: "
            f"{per(base, 'none_rate', '{:.1%}')}; at {worst_noise['noise_px'].iloc[0]:g} px: "
            f"{per(worst_noise, 'none_rate', '{:.1%}')}; with "
            f"{int(worst_false['false_stars'].iloc[0])} false stars: "
            f"{per(worst_false, 'none_rate', '{:.1%}')}. Verified correct rates at the same "
            f"three conditions: {per(base, 'correct_rate', '{:.1%}')}; "
            f"{per(worst_noise, 'correct_rate', '{:.1%}')}; "
            f"{per(worst_false, 'correct_rate', '{:.1%}')}.\n"
            f"* **The paper's typical triangle error** (two observed stars given one catalog "
            f"star, its Table 4) in first hypotheses: {dups}. Each of our hypotheses is a "
            f"one-to-one assignment by construction; the paper's plain triangle method "
            f"identifies star by star from independent triangles.\n"
            f"* **After verification** the wrong solutions over all conditions are: "
            f"{wrong}; they are not traced star by star by any script here.\n")


def _cost(t: pd.DataFrame) -> str:
    g = t.groupby("method", sort=False)
    seq, match = g["seq_ms_median"], g["matcher_ms_median"]
    lines = "; ".join(f"`{m}` {seq.min()[m]:.1f}-{seq.max()[m]:.1f} ms "
                      f"(matcher {match.min()[m]:.1f}-{match.max()[m]:.1f})"
                      for m in g.groups)
    cand = ", ".join(f"`{m}` {v:,.0f}" for m, v in g["cand_median"].median().items())
    return (f"* **\"Reduces computation\".** Median identify time per condition: {lines}. "
            f"Median database candidates per frame (median over conditions): {cand}; the "
            f"counts are of different things (the triangle matcher's catalog triangles in "
            f"its area window, the radial matcher's shortlisted stars), so read them "
            f"within a method.\n")


def section(out: Path, run: dict | None) -> str:
    """The markdown of section 2, or a note when the run has not been made."""
    head = ""  # the renderer writes the section's title
    saved = saved_run(out, run, "radial_triangles.toml")
    if saved is None:
        return head + run_block(None, "scripts/seed002_radial.py")
    t, cfg, px = saved
    cam = cfg.camera
    intro = (f"configs/radial_triangles.toml ({cam.width} x {cam.height} px of "
             f"{px:.1f}\", Hipparcos Hp <= {cfg.sky.mag_limit:g}; {run['view_mean']:.1f} "
             f"stars in view on average, {run['view_min']} to {run['view_max']} over the "
             f"base frames), lost in space over the whole sky (the paper worked within a "
             f"known patch), patterns from the {run['max_stars']} brightest stars. Verified: "
             f"{run['frames']} frames per condition; raw: the first {run['raw_frames']}, the "
             f"first {run['limit']} hypotheses each.\n\n")
    return (head + run_block(run, "scripts/seed002_radial.py") + "\n" + intro
            + f"```\n{fmt_table(t, COLUMNS)}\n```\n\n{LEGEND}\n"
            + "![radial-features misidentifications](figures/seed002_radial_misid.png)\n\n"
            + "### Against the paper's claims\n\n" + PARAMETERS + _rings(run) + _claims(t)
            + _cost(t) + _variants(t))


def _variants(t: pd.DataFrame) -> str:
    text = variant_lines(t, VARIANTS)
    return ("\n### The paper's own variants\n\nRun on the same frames "
            "(`startrack/matchers/radial.py`; select them by name, e.g. "
            "`--methods radial,sss`):\n\n" + text) if text else ""
