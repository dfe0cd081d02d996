"""Section 1 of docs/results.md (seed 000 on the bench), from out/paper2011/'s tables."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from _results_doc import fmt_table, run_block, saved_run, variant_lines

COLUMNS = [("noise", "noise_px", "{:g}"), ("false", "false_stars", None),
           ("method", "method", None), ("n", "frames", None),
           ("correct", "correct_rate", "{:.1%}"), ("wrong", "wrong", None),
           ("top5", "top5_rate", "{:.1%}"), ("ids5", "top5_ids_rate", "{:.1%}"),
           ("raw_n", "raw_frames", None),
           ("raw1_right", "first_right_rate", "{:.1%}"),
           ("raw1_wrong", "first_wrong_rate", "{:.1%}"),
           ("bore\"", "boresight_median_arcsec", "{:.1f}"),
           ("t_bench", "time_median_ms", "{:.2f}"), ("t_seq", "seq_ms_median", "{:.2f}"),
           ("t_match", "matcher_ms_median", "{:.2f}"), ("t/tri", "seq_vs_triangle", "{:.2f}"),
           ("cand", "cand_median", "{:.0f}"), ("pivots", "pivots_mean", "{:.2f}"),
           ("hyps", "hyps_mean", "{:.2f}"), (">=3real", "top3_rate", "{:.1%}")]
FOV_COLUMNS = [("fov", "fov_deg", "{:g}"), ("noise", "noise_px", "{:g}"),
               ("false", "false_stars", None), ("method", "method", None),
               ("n", "frames", None), ("in_view", "view_mean", "{:.1f}"),
               ("min", "view_min", None), ("max", "view_max", None),
               ("correct", "correct_rate", "{:.1%}"), ("wrong", "wrong", None),
               ("t_bench", "time_median_ms", "{:.2f}")]
LEGEND = """\
Columns: `correct`, `wrong` (count) verified over `n` frames; `top5`: verified and right
when `identify()` sees only the five brightest spots; `ids5`: the full verified solution
scored on the five brightest spots only; `raw1_right/raw1_wrong`: the unverified first
hypothesis over `raw_n` frames (the rest: no hypothesis); `bore"`: median boresight error
of correct solutions; `t_bench`: bench median ms (worker processes); `t_seq`: median of the
best-of-repeats times in one process, `t_match` the part of it inside the matcher, `t/tri`
`t_seq` over the triangle method's in the same condition; `cand`: median database
candidates per frame (angle, hybrid: catalog pairs from the angle lookups; triangle:
catalog triangles in the area window); `pivots`, `hyps`: mean pivots and hypotheses
verified per frame (`raw_n` frames); `>=3real`: frames with at least 3 real stars among
the 5 brightest spots.
"""


def _pick(t: pd.DataFrame, method: str, col: str, **where) -> pd.Series:
    m = t["method"] == method
    for k, v in where.items():
        m &= t[k] == v
    return t.loc[m].sort_values(list(where) or "condition")[col]


def _join(values, form: str) -> str:
    return ", ".join(form.format(v) for v in values)


def _speed(t: pd.DataFrame) -> str:
    noisy = dict(false_stars=0)
    hyb = _pick(t, "hybrid", "seq_vs_triangle", **noisy)
    ang = _pick(t, "angle", "seq_vs_triangle", **noisy)
    levels = _pick(t, "hybrid", "noise_px", **noisy)
    fs = _pick(t, "hybrid", "seq_vs_triangle", noise_px=0.0)
    tc = _pick(t, "triangle", "cand_median", **noisy)
    hc = _pick(t, "hybrid", "cand_median", **noisy)
    mt = t[t["method"] == "triangle"].set_index("condition")["matcher_ms_median"]
    mh = t[t["method"] == "hybrid"].set_index("condition")["matcher_ms_median"]
    ratio = (mh / mt).dropna()
    return (f"* **\"Faster than the triangle method\".** In the sequential timing the hybrid "
            f"takes {_join(hyb, '{:.2f}')} of the triangle method's time at centroid noise "
            f"{_join(levels, '{:g}')} px, and {_join(fs, '{:.2f}')} with false stars; the "
            f"angle method {_join(ang, '{:.2f}')}. Counting the matcher alone (`t_match`), "
            f"the hybrid takes {ratio.min():.2f}-{ratio.max():.2f} of the triangle "
            f"matcher's time. The triangle method's area window returns a median of "
            f"{_join(tc, '{:,.0f}')} catalog triangles per frame over the same noise levels, "
            f"the hybrid's pair lookups {_join(hc, '{:,.0f}')} catalog pairs.\n")


def _accuracy(t: pd.DataFrame) -> str:
    fs = t[(t["noise_px"] == 0) & (t["false_stars"] > 0)]
    counts = _join(sorted(fs["false_stars"].unique()), "{:g}")
    a = fs[fs["method"] == "angle"].sort_values("false_stars")
    more = bool((a["first_wrong_rate"].to_numpy()
                 > _pick(fs, "hybrid", "first_wrong_rate").to_numpy()).all())
    verdict = "true of the raw matchers with false stars" if more else \
        "not in every false-star condition, raw"
    text = (f"* **\"More accurate than the angle method\": {verdict}.** Raw, the angle "
            f"method's first hypothesis is wrong in "
            f"{_join(a['first_wrong_rate'], '{:.1%}')} of frames with {counts} false stars "
            f"(triangle: {_join(_pick(fs, 'triangle', 'first_wrong_rate'), '{:.1%}')}; "
            f"hybrid: {_join(_pick(fs, 'hybrid', 'first_wrong_rate'), '{:.1%}')}).")
    if "pairs_off_frames" in a:
        off, n = int(a["pairs_off_frames"].sum()), int(a["first_wrong_frames"].sum())
        text += (f" In {off} of these {n} wrong first hypotheses at least one of the pair "
                 f"angles misses the catalog angle by more than the matcher's tolerance "
                 f"(`first_pairs_off` in `startrack/bench/raw.py`), so they are not chance "
                 f"catalog triangles: such a pair was never checked, because the chain stops "
                 f"as soon as one candidate is left after a star joins, before the closing "
                 f"angle to the earlier stars is looked up (`_chain` in "
                 f"`startrack/matchers/angle.py`).")
    v = t[(t["false_stars"] == 0)]
    h = _pick(v, "hybrid", "first_wrong_rate")
    return text + (f" With centroid noise and no false stars the hybrid's first hypothesis is "
                   f"wrong in {_join(h, '{:.1%}')} of frames at "
                   f"{_join(_pick(v, 'hybrid', 'noise_px'), '{:g}')} px.\n")


def _rest(t: pd.DataFrame) -> str:
    fs = t[(t["noise_px"] == 0) & (t["false_stars"] > 0)]
    best_other = np.maximum(_pick(fs, "angle", "correct_rate").to_numpy(),
                            _pick(fs, "triangle", "correct_rate").to_numpy())
    gain = _pick(fs, "hybrid", "correct_rate").to_numpy() - best_other
    robust = ("yes, after verification" if (gain > 0.01).all() else
              "not after verification (within a point of the better of the two, or behind)")
    hp = t[t["method"] == "hybrid"]["pivots_mean"]
    lit = t[t["method"] == "hybrid_nofourth"]["pivots_mean"]
    lit_text = (f"; without the check (`hybrid_nofourth`) {lit.max():.2f}" if len(lit)
                else "")
    return (f"* **\"No pivoting\": in name only.** Every hypothesis the hybrid yields has "
            f"passed its fourth-star check, a lookup of a further observed star against "
            f"the triangle's catalog stars: what the Pyramid matcher counts as a pivot. "
            f"Counted so, the hybrid makes {hp.min():.2f}-{hp.max():.2f} pivots per frame "
            f"(mean per condition){lit_text}; the variants below show what the check "
            f"buys.\n"
            f"* **\"More robust to false stars than either method\": {robust}.** Verified "
            f"correct rates with "
            f"{_join(_pick(fs, 'angle', 'false_stars'), '{:g}')} false stars: angle "
            f"{_join(_pick(fs, 'angle', 'correct_rate'), '{:.1%}')}, triangle "
            f"{_join(_pick(fs, 'triangle', 'correct_rate'), '{:.1%}')}, hybrid "
            f"{_join(_pick(fs, 'hybrid', 'correct_rate'), '{:.1%}')}. All are capped by the "
            f"five-star budget: the frames with at least 3 real stars among the five "
            f"brightest spots are {_join(_pick(fs, 'hybrid', 'top3_rate'), '{:.1%}')}.\n"
            f"* **Five stars only.** When `identify()` sees only the five brightest spots, "
            f"the shared verification accepts {t['top5_rate'].min():.1%} to "
            f"{t['top5_rate'].max():.1%} of frames right (`top5`)"
            + (": with no star outside the pattern it never reaches its false-match bound."
               if t["top5_rate"].max() == 0 else ".")
            + f" Scored on the five "
            f"brightest spots only, the full verified solutions are right in "
            f"{t['top5_ids_rate'].min():.1%} to {t['top5_ids_rate'].max():.1%} (`ids5`).\n"
            f"* The verified `wrong` counts ({int(t['wrong'].min())} to "
            f"{int(t['wrong'].max())} per condition) are not traced by any script here.\n")


VARIANTS = [("angle", "angle_closed", "every closing angle looked up"),
            ("angle", "angle_open", "no closing angle: the paper's chain"),
            ("triangle", "triangle_nopivot", "no forced pivot on a unique triangle"),
            ("hybrid", "hybrid_nofourth", "no fourth-star check: the paper's \"no pivoting\"")]


def _variants(t: pd.DataFrame) -> str:
    text = variant_lines(t, VARIANTS)
    if not text:
        return ""
    return ("### The paper's own variants\n\nEach variant is ours with one choice put "
            "back to the paper's text (or, for `angle_closed`, to the strict one), run on "
            "the same frames (`startrack/matchers/`; select them by name, e.g. "
            "`--methods angle,angle_open`):\n\n" + text + "\n")


def _fov(out: Path, run: dict) -> str:
    path = out / "fov.csv"
    if not path.exists():
        return ""
    f = pd.read_csv(path)
    by = f.groupby("fov_deg")["view_mean"].first()
    r = run["reading"]
    base = f[(f["noise_px"] == 0) & (f["false_stars"] == 0)]
    rates = {fov: _join(g.sort_values("method")["correct_rate"], "{:.1%}")
             for fov, g in base.groupby("fov_deg")}
    names = _join(sorted(base["method"].unique()), "{}")
    return (f"### Field width\n\nThe same sky, 1024 px and five brightest stars at "
            f"{_join(by.index, '{:g}')} deg ({run['fov_frames']} frames per condition; "
            f"`fov.csv`):\n\n```\n{fmt_table(f, FOV_COLUMNS)}\n```\n\n"
            f"* Stars in view scale with the field's area ({_join(by, '{:.1f}')} on "
            f"average). With exact centroids the correct rates ({names}) are "
            + "; ".join(f"{k:g} deg: {v}" for k, v in rates.items())
            + ". What changes with the field is the number of stars per field (`in_view`, "
            f"`min`) and the angle one pixel of noise stands for.\n"
            f"* **\"0.025 x 0.025\" read as {r['fov_rad']:g} rad** ({r['fov_deg']:.2f} deg): "
            f"over the whole sphere 2000 stars give {r['whole_sky_in_view']:.2f} star per "
            f"field, so the 2000 stars must fill a patch. For the {r['view_mean']:.1f} "
            f"stars per field of our base run, the patch is {r['patch_side_deg']:.1f} "
            f"deg square ({r['patch_fraction_of_sky']:.2%} of the sky). That reading is the "
            f"same problem as ours scaled down: the same stars and catalog pairs per field "
            f"and, on the same pixel count, the same noise relative to the pattern; it "
            f"differs by the patch's edges (fields near them hold fewer stars) and by a "
            f"catalog that knows where the camera points. It is not simulated here.\n")


def section(out: Path, run: dict | None) -> str:
    """The markdown of section 1, or a note when the run has not been made."""
    head = ""  # the renderer writes the section's title
    saved = saved_run(out, run, "paper2011.toml")
    if saved is None:
        return head + run_block(None, "scripts/paper2011.py")
    t, cfg, px = saved
    cam = cfg.camera
    fov = float(np.degrees(2 * np.arctan(cam.width / 2 / cam.f_px)))
    noise = _join(sorted(t["noise_px"].unique()), "{:g}")
    false = _join(sorted(t.loc[t["false_stars"] > 0, "false_stars"].unique()), "{:g}")
    intro = (f"configs/paper2011.toml (random 2000-star sky, {cam.width} x {cam.height}, "
             f"{fov:g} deg: {run['view_mean']:.1f} stars in view on average, {run['view_min']} "
             f"to {run['view_max']} over the base frames), patterns from the 5 brightest "
             f"observed stars, methods {_join(t['method'].unique(), '{}')}. Conditions: "
             f"centroid noise {noise} px (1 px = {px:.1f}\") with no false stars, and "
             f"{false} false stars at no noise. Verified: {run['frames']} frames per "
             f"condition; raw, five-star and `t_seq`: the first {run['timing_frames']} "
             f"(best of {run['repeats']}).\n\n")
    return (head + run_block(run, "scripts/paper2011.py") + "\n" + intro
            + f"```\n{fmt_table(t, COLUMNS)}\n```\n\n{LEGEND}\n"
            + "![seed 000 sweeps](figures/paper2011_sweeps.png)\n\n"
            + "### Against the paper's claims\n\n" + _speed(t) + _accuracy(t) + _rest(t)
            + "\n" + _variants(t) + _fov(out, run))
