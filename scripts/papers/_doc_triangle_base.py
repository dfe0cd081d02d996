"""The 2011 triangle-base paper's section of docs/results.md, rendered from the tables
scripts/papers/paper2011.py saves in docs/data/triangle-base-2011/ (every number from them)."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from scripts.papers import _paper2011_claims as claims
from scripts.papers import _verdicts
from scripts.papers._doc_triangle_setup import MAIN, arcsec_per_px, false_rule, field_width
from scripts.papers._doc_triangle_setup import rate as _rate
from scripts.papers._results_doc import run_block
from startrack.bench import format_p
from startrack.matchers import get_matcher

WHAT = {
    "angle": "ours: pair lookups, pivots until one answer, up to 4 ambiguous answers and 5 "
             "skipped stars per chain handed to verification",
    "angle_closed": "ours with every closing angle looked up",
    "angle_open": "the paper's chain: one chain from the three brightest stars, each pivot "
                  "shares one star with the last pair, no closing angle, no skipped star; "
                  "a chain that does not end with one answer is indeterminate; two stars "
                  "answer when their angle's window holds one catalog pair",
    "triangle": "ours (Cole and Crassidis): area and polar moment, pivots along the chain, "
                "at least one pivot",
    "triangle_nopivot": "ours without the forced pivot on a unique triangle",
    "triangle_first": "the paper's: pivots on triangles sharing two stars with the first "
                      "triangle, only while several answers are left; one answer or none",
    "hybrid": "ours: angle votes shortlist, triangles over the shortlist, vote relaxation "
              "passes, a fourth-star check, 5 hypotheses per triangle",
    "hybrid_nofourth": "ours without the fourth-star check",
    "hybrid_single": "the paper's hybrid and nothing more: a catalog star is a candidate "
                     "of an observed star when any of that star's angle lookups holds it "
                     "(the paper gives no voting rule: the simplest reading), then area and "
                     "polar moment over the candidates; a triangle answers only when one "
                     "catalog triangle passes; no pivot, no fourth star, no mirror check",
}
NO_TREE = """\
* **The binary test tree is not built.** The paper's triangle section names it in one
  sentence ("to reduce the number of combinations in 3 tests, a binary test tree is
  created", quoted under C9) and gives no structure for it: its only figure of the method
  is a flowchart whose content is not in the text. What it is for, cutting the
  combinations of the area, polar-moment and side tests, is done here by the k-vector
  range on area, the polar-moment filter on that range and the sorted join of the pivots
  (`startrack/_core/matchers/triangles.pyx`, `triangle_search.pxi`).
"""


def _cond(r) -> str:
    return f"{r['noise_px']:g} px, {int(r['false_stars'])} false"


def _wrong(pooled) -> str:
    """The wrong answers beside the right ones: "a / b" rates, "-" for a measure with no
    right or wrong answer."""
    if "wrong_a" not in pooled or pd.isna(pooled["wrong_a"]):
        return "-"
    n = int(pooled["n"])
    return f"{_rate(pooled['wrong_a'], n)} / {_rate(pooled['wrong_b'], n)}"


def _test_line(rows: pd.DataFrame) -> tuple[str, str]:
    pooled = rows.iloc[-1]
    word, detail = claims.verdict(rows)
    cites = f"{rows['row'].iloc[-1]}; {rows['row'].iloc[0]} to {rows['row'].iloc[-2]}"
    n = int(pooled["n"])
    line = (f"| {pooled['test']} | {claims.MEASURES[pooled['measure']]} | `{pooled['a']}` "
            f"vs `{pooled['b']}` | {pooled['scope']} ({claims.CLOSEST[pooled['scope']]}) | "
            f"{n} | {_rate(pooled['k_a'], n)} | {_rate(pooled['k_b'], n)} | {_wrong(pooled)} "
            f"| {int(pooled['only_a'])} / {int(pooled['only_b'])} | {format_p(pooled['p'])} | "
            f"**{word}** ({detail}) | {cites} |\n")
    return line, word


def _per_condition(rows: pd.DataFrame) -> str:
    """Every test's per-condition counts and Holm-corrected p-values, one line a test."""
    lines = []
    for _, g in rows.groupby("test", sort=True):
        cond = g.iloc[:-1]
        holm = _verdicts.holm(cond["p"].to_numpy())
        cells = [f"{c} {int(a)}/{int(b)} {format_p(q)}" for c, a, b, q in
                 zip(cond["condition"], cond["only_a"], cond["only_b"], holm, strict=True)]
        lines.append(f"* test {g['test'].iloc[0]}: " + "; ".join(cells))
    return ("<details><summary>per condition: a only / b only, Holm-corrected p</summary>"
            "\n\n" + "\n".join(lines) + "\n\n</details>\n")


def claim_words(folder: Path) -> dict[str, tuple[str, str]]:
    """Each claim's (verdict, what it rests on) from the saved tables: its paired tests',
    or for C9 (no two methods compared) the count's."""
    table = pd.read_csv(folder / "claims.csv")
    out = {}
    for c in claims.CLAIMS:
        rows = table[table["claim"] == c.key]
        if len(rows):
            out[c.key] = (claims.claim_verdict(rows), "paired tests")
        else:
            v = hundreds_verdict(pd.read_csv(folder / "table.csv"))
            out[c.key] = (v.word, v.detail)
    return out


def _claim_block(claim: claims.Claim, table: pd.DataFrame, extra: str,
                 word: str = "") -> str:
    quote = f"> {claim.original}\n"
    if claim.english:
        quote += (f"\n*Reassembled from the stored text; translation (ours):* "
                  f"\"{claim.english}\"\n")
    text = f"#### {claim.key}. {claim.where}\n\n{quote}\n"
    rows = table[table["claim"] == claim.key]
    if len(rows):
        text += ("| test | per frame | a vs b | scope (closest) | frames | a [95% CI] | "
                 "b [95% CI] | wrong a / b | a only / b only | pooled p | verdict | rows |\n"
                 + "|---" * 12 + "|\n")
        for _, g in rows.groupby("test", sort=True):
            text += _test_line(g)[0]
        text += "\n" + _per_condition(rows)
    overall = word or claims.claim_verdict(rows)
    if overall == _verdicts.ONLY_UNDER and len(rows):
        overall += " the conditions and for the methods named above"
    note = f" ({claim.note})" if claim.note else ""
    return text + f"\n**Verdict: {overall}**{note}.\n{extra}\n"


def _pick(t: pd.DataFrame, method: str, **where) -> pd.DataFrame:
    m = t["method"] == method
    for k, v in where.items():
        m &= t[k] == v
    return t[m].sort_values(["noise_px", "false_stars"])


def _join(values, form: str) -> str:
    return ", ".join(form.format(v) for v in values)


def _speed(timing: pd.DataFrame) -> str:
    def ratio(a: str, b: str, col: str) -> pd.Series:
        ta = timing[timing["method"] == a].set_index("condition")[col]
        tb = timing[timing["method"] == b].set_index("condition")[col]
        return (ta / tb).dropna()

    parts = []
    for a, b in (("hybrid", "triangle"), ("hybrid_single", "triangle_first"),
                 ("angle", "triangle")):
        med, p95 = ratio(a, b, "seq_ms_median"), ratio(a, b, "seq_ms_p95")
        mat = ratio(a, b, "matcher_ms_median")
        if len(med):
            parts.append(f"`{a}` takes {med.min():.2f} to {med.max():.2f} times `{b}`'s "
                         f"median identify time over the timed conditions (p95: "
                         f"{p95.min():.2f} to {p95.max():.2f}; inside the matcher alone "
                         f"{mat.min():.2f} to {mat.max():.2f})")
    return "* " + ";\n* ".join(parts) + " (timing table below).\n" if parts else ""


def _narrowing(t: pd.DataFrame) -> str:
    noise = t[t["false_stars"] == 0]
    tri = _pick(noise, "triangle")
    ang = _pick(noise, "angle")
    return (f"* Per lookup (medians over the raw frames at noise "
            f"{_join(tri['noise_px'], '{:g}')} px, no false star): the triangle's area "
            f"window holds {_join(tri['area_per_lookup'], '{:,.0f}')} catalog triangles, "
            f"of which the polar-moment filter keeps "
            f"{_join(tri['kept_per_lookup'], '{:,.1f}')}; an angle lookup's window holds "
            f"{_join(ang['kept_per_lookup'], '{:,.1f}')} catalog pairs. The `cand` of "
            f"earlier versions of this page counted the area window, before the filter.\n")


def _false(t: pd.DataFrame) -> str:
    fs = t[(t["noise_px"] == 0) & (t["false_stars"] > 0)]
    lines = []
    for m in ("angle", "triangle", "hybrid", "hybrid_single"):
        r = _pick(fs, m)
        if len(r):
            lines.append(f"`{m}` raw " + _join(
                [_rate(a, b) for a, b in zip(r["first_right"], r["raw_frames"], strict=True)],
                "{}") + "; verified " + _join(
                [_rate(a, b) for a, b in zip(r["correct"], r["frames"], strict=True)], "{}"))
    h = _pick(fs, "hybrid")
    cap = _join([_rate(a, b) for a, b in zip(h["real3"], h["raw_frames"], strict=True)], "{}")
    return (f"* At no noise with {_join(h['false_stars'], '{:d}')} false stars: "
            + ";\n  ".join(lines) + f". The frames with at least 3 real stars among the 5 "
            f"brightest spots (no method can do better raw) are {cap} of the raw frames; "
            f"the raw and verified rates are over different frame counts (`raw_frames`, "
            f"`frames` in table.csv).\n")


def _pivots(t: pd.DataFrame) -> str:
    parts = [f"`{m}` {_pick(t, m)['pivots_mean'].min():.2f} to "
             f"{_pick(t, m)['pivots_mean'].max():.2f}"
             for m in ("hybrid", "hybrid_single", "triangle", "triangle_first")
             if len(_pick(t, m))]
    s = _pick(t[t["false_stars"] == 0], "hybrid_single")
    wrong = _join([_rate(a, b) for a, b in zip(s["first_wrong"], s["raw_frames"], strict=True)],
                  "{}")
    return (f"* Mean pivots per frame over the grid's conditions: {'; '.join(parts)}. "
            f"`hybrid_single`'s first hypothesis is wrong in {wrong} of the raw frames at "
            f"noise {_join(s['noise_px'], '{:g}')} px (no false star).\n")


def hundreds_verdict(t: pd.DataFrame) -> _verdicts.Verdict:
    """C9 ("hundreds of answers for every triangle"): the median catalog triangles one
    lookup keeps after area and polar moment together, as the paper's triangle test
    applies them, per noise level (no false star); at least 100 meets "hundreds"."""
    tri = _pick(t[t["false_stars"] == 0], "triangle")
    holds = {f"{n:g} px/0 false": bool(k >= 100)
             for n, k in zip(tri["noise_px"], tri["kept_per_lookup"], strict=True)}
    return _verdicts.judge_count(holds, [claims.CLOSEST["noise"]],
                                 "a median of at least 100 after the polar-moment filter")


def _hundreds(t: pd.DataFrame) -> str:
    tri = _pick(t[t["false_stars"] == 0], "triangle")
    v = hundreds_verdict(t)
    return f"* The count: **{v.word}** ({v.detail}).\n" + (
        f"* Median catalog triangles in one lookup after the area and polar-moment tests "
        f"together (the paper's triangle test) at noise {_join(tri['noise_px'], '{:g}')} "
        f"px: {_join(tri['kept_per_lookup'], '{:,.1f}')} (\"hundreds\" means at least 100 "
        f"here); in the area window alone, before the polar-moment filter, "
        f"{_join(tri['area_per_lookup'], '{:,.0f}')}.\n")


def _grid(t: pd.DataFrame, count: str, trials: str) -> str:
    """Rate [95% Wilson interval] per condition (rows) and method (columns)."""
    methods = [m for m in MAIN if m in set(t["method"])]
    cells = t.assign(cell=[_rate(k, n) for k, n in zip(t[count], t[trials], strict=True)])
    grid = cells.pivot_table(index=["noise_px", "false_stars"], columns="method",
                             values="cell", aggfunc="first")[methods]
    grid.index = [f"{n:g} px, {int(f)} false" for n, f in grid.index]
    return grid.to_string()


def _timing(timing: pd.DataFrame) -> str:
    t = timing.copy()
    t["cell"] = [f"{a:.2f} / {b:.2f} ({r:.2f})" for a, b, r in
                 zip(t["seq_ms_median"], t["seq_ms_p95"], t["vs_triangle"], strict=True)]
    grid = t.pivot_table(index=["noise_px", "false_stars"], columns="method", values="cell",
                         aggfunc="first")
    grid = grid[[m for m in MAIN if m in grid.columns]]
    grid.index = [f"{n:g} px, {int(f)} false" for n, f in grid.index]
    return grid.to_string()


def _intro(run: dict, t: pd.DataFrame) -> str:
    methods = [m for m in dict.fromkeys(t["method"])]
    rows = "\n".join(f"* `{m}`: {WHAT.get(m, get_matcher(m).description)}."
                     for m in methods)
    return (f"configs/paper2011.toml: a random 2000-star sky, 1024 x 1024 px over 17.5 deg"
            f"{arcsec_per_px(run)} ({run['view_mean']:.1f} stars in view on average, "
            f"{run['view_min']} to {run['view_max']} over the base frames), patterns from "
            f"the 5 brightest spots, no fainter star added. Conditions: every combination "
            f"of centroid noise {_join(sorted(t['noise_px'].unique()), '{:g}')} px and "
            f"{_join(sorted(t['false_stars'].unique()), '{:d}')} false stars. Verified: "
            f"{run['frames']} frames per condition; raw: the first {run['raw_frames']}; "
            f"timing: the first {run['timing_frames']} of the two one-axis sweeps. Every "
            f"method sees the same frames, so two methods are compared frame by frame "
            f"(exact McNemar test; the sign test for times and counts). Rates carry 95% "
            f"Wilson intervals. The methods:\n\n{rows}\n")


def section(folder: Path, run: dict) -> str:
    """The section's markdown from the tables saved in ``folder``."""
    t = pd.read_csv(folder / "table.csv")
    timing = pd.read_csv(folder / "timing.csv")
    table = pd.read_csv(folder / "claims.csv")
    fov = pd.read_csv(folder / "fov.csv") if (folder / "fov.csv").stat().st_size > 1 \
        else pd.DataFrame()
    hundreds = _hundreds(t)
    extra = {"C1": "", "C2": _narrowing(t), "C3": _speed(timing), "C4": "",
             "C5": _pivots(t), "C6": _false(t), "C7": "", "C8": "",
             "C9": hundreds}
    words = claim_words(folder)
    blocks = "".join(_claim_block(c, table, extra[c.key], words[c.key][0])
                     for c in claims.CLAIMS)
    load = run["timing_load"]
    return (run_block(run, "scripts/papers/paper2011.py") + "\n" + _intro(run, t)
            + "\n### Claims and verdicts\n\nEach test asks whether `a` does better than "
              "`b` on the frames of its scope, judged by the rules at the top of this page "
              "from the pooled row and the per-condition rows of `claims.csv` (Holm-"
              f"corrected over the scope's conditions; significant means p < "
              f"{claims.ALPHA:g}). `scope (closest)`: the conditions, and the one closest "
              "to the paper's stated setting (the paper names no noise level or false-star "
              "count for its claims: the least of both in the scope). `wrong a / b`: beside "
              "a rate of right answers, the frames answered wrongly (verified: accepted but "
              "wrong; raw: a first hypothesis that is wrong). `a only / b only`: the frames "
              "where one succeeds and the other does not, the only ones a paired test "
              "reads. `rows`: the pooled row, then the per-condition rows, of "
              "`docs/data/triangle-base-2011/claims.csv`. The Persian sentences are the "
              "paper's abstract and triangle section, reassembled from the stored text's "
              "scrambled lines (the word order is ours, every word as the text has it); "
              "the translations are ours.\n\n" + blocks + NO_TREE
            + "\n### Rates over the grid\n\nVerified and right, `frames` per cell:\n\n"
              f"```\n{_grid(t, 'correct', 'frames')}\n```\n\nFirst hypothesis right, "
              f"unverified, `raw_frames` per cell:\n\n```\n"
              f"{_grid(t, 'first_right', 'raw_frames')}\n```\n\n"
              "Verified and right when `identify()` sees only the five brightest spots "
              "(`top5`: the papers' budget, no other star to confirm with), over the raw "
              f"frames:\n\n```\n{_grid(t, 'top5', 'raw_frames')}\n```\n\n"
              f"![rates]({run['figure'].removeprefix('docs/')})\n\n"
            + "### Timing\n\nMedian / p95 ms of the fastest of "
              f"{run['repeats']} identify() runs per frame (verification included), and "
              "the median over `triangle`'s in parentheses; one process, methods "
              f"interleaved frame by frame, after {run['warmup']} untimed frames per "
              f"method; on {run['CPU']} ({run['cpus']} CPUs shared with other work), load "
              f"average {load[0]:g} at the start and {load[3]:g} at the end of the "
              f"timing:\n\n```\n{_timing(timing)}\n```\n\n" + field_width(fov, run)
            + false_rule(folder, run))


def summary(folder: Path, run: dict) -> str:
    """One sentence for the README: each claim's verdict, as the section gives it (the
    same words, grouped by scripts/papers/_verdicts.py)."""
    words = claim_words(folder)
    said = _verdicts.roll_up([(f"{c.short} ({c.key})", words[c.key][0])
                              for c in claims.CLAIMS])
    return (f"{len(claims.CLAIMS)} claims quoted in full, judged on {run['frames']} "
            f"verified and {run['raw_frames']} raw frames per condition: {said}")
