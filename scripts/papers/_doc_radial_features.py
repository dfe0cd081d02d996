"""The radial-features paper's section of docs/results.md, from docs/data/radial-features/
(saved by scripts/papers/radial_features.py): every claim with its verdict, then the tables."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from scripts.papers import _radial_claims, _verdicts
from scripts.papers._radial_claims import CLAIMS
from scripts.papers._radial_plot import LABEL_COLUMNS
from scripts.papers._radial_tables_doc import our_tables_text, paper_tables_text
from scripts.papers._results_doc import fmt_table, run_block
from startrack.bench import format_p, format_rate, wilson

BENCH_COLUMNS = [("noise", "noise_px", "{:g}"), ("false", "false_stars", None),
                 ("method", "method", None), ("n", "frames", None),
                 ("correct [95%]", "correct_ci", None), ("wrong", "wrong", None),
                 ("raw_n", "raw_frames", None), ("raw1_right [95%]", "raw_ci", None),
                 ("raw_none", "none", None), ("raw1_wrong", "first_wrong_frames", None),
                 ("dup", "duplicates", None), ("t_bench", "time_median_ms", "{:.1f}"),
                 ("t_seq", "seq_ms_median", "{:.1f}"),
                 ("p95", "seq_ms_p95", "{:.1f}"), ("t_match", "matcher_ms_median", "{:.1f}"),
                 ("cand", "cand_median", "{:.0f}"), ("short", "shortlist_mean", "{:.1f}")]
RATES = [("recall", "recall", "{:.3f}"), ("precision", "precision", "{:.3f}")]
METHOD = """\
**What is compared.** The paper's baseline is the classic side-side-side triangle test
(its equation 5) over every navigation star: `sss` (lost in space, through the catalog's
pair table) and `sss_patch` (the catalog stars of the known patch). The improved method
is the same test over each star's radial shortlist: ours, `radial` and `radial_patch`
(R from the catalog density, rings a few noise sigmas wide, l over the rings the observed
star occupies, ring edges tolerant of noise, at most 10 candidates), and the paper's as
written, `radial_paper` and `radial_paper_patch` (R and dr the largest and smallest
separation among the observed and the navigation stars, l >= 3/4 Nq over every ring,
bits as measured; at most 50 candidates, a bound on memory). Our `sss` adds to equation
5 a mirror check, a fourth star ordering the hypotheses and at most 8 catalog triangles
per observed one; `sss_paper_patch` is equation 5 alone (every catalog triangle whose
three sides lie within eps, in catalog order), the paper's baseline as written, beside
`sss_patch` in the paper's setting; every star labelled, the two are one method (the
labelling rule below is equation 5), so only `sss_patch` is labelled. `triangle` is our
planar triangle matcher, a different method, shown for scale.

**Every star identified** (the paper's Figures 5 and 6, Tables 3 and 4): each observed
star forms triangles with pairs of its 4 nearest observed stars; a triangle matching
exactly one catalog triangle votes for its three stars' identities; a star takes the
catalog star with the most votes, none on a tie (`startrack/bench/_star_labels.py`).
Stars are labelled one by one, so two can get the same catalog star, as in the paper's
Table 4. A misidentified star is one labelled with a wrong catalog star, or a false star
labelled at all.

"""
LEGEND = """\
`correct`: verified solutions with every identity right, over `n` frames, with the 95%
Wilson interval; `wrong`: accepted but wrong. Raw (the matcher's first hypothesis,
unverified) over `raw_n` frames: `raw1_right`, `raw_none` (no hypothesis), `raw1_wrong`,
`dup` (a catalog star given to two observed stars). Time, in worker processes after the
bench's warm-up frame (no compile, import or table load inside a timed span): `t_bench`
median identify() of the verified run; `t_seq` median and `p95` of identify() in the raw
pass, run after the raw scoring of the same frame, so a per-frame table the matcher
caches (`radial_paper`'s rings) is built before it and left out; `t_match` its matcher part;
`cand`: median candidates per frame (the radial family: shortlisted stars; `sss`: every
catalog star; `triangle`: catalog triangles in its area window); `short`: mean shortlist.
"""


def _ci(k: pd.Series, n: pd.Series) -> pd.Series:
    low, high = wilson(k, n)
    return pd.Series([f"{a / b:.1%} [{100 * lo:.1f}, {100 * hi:.1f}]" if b else "-"
                      for a, b, lo, hi in zip(k, n, low, high, strict=True)], index=k.index)


def _identified(labels: pd.DataFrame, method: str) -> str:
    r = labels[labels["method"] == method]
    if r.empty:
        return f"`{method}` not labelled"
    ident, right = int(r["identified"].sum()), int(r["right"].sum())
    return (f"`{method}` labels {format_rate(right, int(r['real'].sum()))} of the real "
            f"stars right (recall), {int(r['misidentified'].sum())} stars wrongly "
            f"({int(r['false_labelled'].sum())} of them false stars; precision "
            f"{format_rate(right, ident) if ident else '-'})")


SETTINGS = {"radial": "lost in space", "radial_patch": "in the paper's setting, a known patch"}
TEST_HEAD = ("| test | per frame | a vs b | frames | a [95% CI] | b [95% CI] | "
             "a only / b only | pooled p | verdict |\n" + "|---" * 9 + "|\n")


def _test_line(k: int, test, paired: pd.DataFrame) -> str:
    v = _radial_claims.judge(paired, test)
    found = _radial_claims.test_rows(paired, test)
    if found is None:
        return f"| {k} | {test.measure} | `{test.a}` vs `{test.b}` | - | - | - | - | - | " \
               f"**{v.word}** ({v.detail}) |\n"
    _, pooled = found
    n = int(pooled.frames)
    sense = " (as good)" if test.sense == "as good" else ""
    return (f"| {k} | {test.measure}{sense} | `{test.a}` vs `{test.b}` | {n} | "
            f"{format_rate(int(pooled.a_ok), n)} | {format_rate(int(pooled.b_ok), n)} | "
            f"{int(pooled.only_a)} / {int(pooled.only_b)} | {format_p(pooled.p)} | "
            f"**{v.word}** ({v.detail}) |\n")


def _per_condition(tests, paired: pd.DataFrame) -> str:
    lines = []
    for k, test in enumerate(tests, 1):
        found = _radial_claims.test_rows(paired, test)
        if found is None:
            continue
        cond, _ = found
        holm = _verdicts.holm(cond["p"].to_numpy())
        lines.append(f"* test {k}: " + "; ".join(
            f"{c} {int(a)}/{int(b)} {format_p(q)}" for c, a, b, q in
            zip(cond["condition"], cond["only_a"], cond["only_b"], holm, strict=True)))
    return ("<details><summary>per condition: a only / b only, Holm-corrected p</summary>"
            "\n\n" + "\n".join(lines) + "\n\n</details>\n") if lines else ""


def _table3(ours: pd.DataFrame) -> _verdicts.Verdict:
    t2, t3 = ours[ours["table"] == 2], ours[ours["table"] == 3]
    several = int((t2.groupby("star").size() > 1).sum()) if len(t2) else 0
    doubtful = int((~t2.groupby("star")["true"].all()).sum()) if len(t2) else 0
    given = t3[t3["ra"].notna()]
    wrong = int((~given["true"].astype(bool)).sum())
    said = (f"after the radial step (our Table 2) {several} of the ten brightest stars "
            f"have several candidates and {doubtful} have a wrong one; the triangle step "
            f"(our Table 3) labels {len(given)} stars, {wrong} wrongly")
    if doubtful == 0:
        return _verdicts.Verdict(_verdicts.NOT_TESTABLE, said + "; the radial step leaves "
                                 "no wrong candidate to remove: a frame whose shortlists "
                                 "hold wrong candidates would test it (the per-image "
                                 "counts over every frame are C8's)")
    if wrong < doubtful:
        return _verdicts.Verdict(_verdicts.ONLY_UNDER, "our one frame: " + said)
    return _verdicts.Verdict(_verdicts.NOT_REPRODUCED, said)


def claim_verdicts(claim, t: pd.DataFrame, paired: pd.DataFrame,
                   ours: pd.DataFrame) -> tuple[str, list[_verdicts.Verdict]]:
    """(the claim's word, its tests' verdicts) by the rules of scripts/papers/_verdicts.py."""
    if claim.tests:
        found = [_radial_claims.judge(paired, test) for test in claim.tests]
    elif claim.kind in ("shortlist", "literal"):
        found = [_radial_claims.shortlist_verdict(t, claim.kind)]
    else:
        found = [_table3(ours)]
    return _verdicts.judge_claim([v.word for v in found]), found


def _evidence(claim, t, labels, paired, ours) -> str:
    word, found = claim_verdicts(claim, t, paired, ours)
    text = ""
    if claim.tests:
        text += "\n" + TEST_HEAD + "".join(
            _test_line(k, test, paired) for k, test in enumerate(claim.tests, 1))
        text += "\n" + _per_condition(claim.tests, paired)
        methods = dict.fromkeys(m for test in claim.tests for m in (test.a, test.b))
        if claim.kind in ("misid", "duplicates"):
            text += "\n" + "".join(f"* {_identified(labels, m)}\n" for m in methods
                                   if m in set(labels["method"]))
        if claim.kind == "time":
            med = t.groupby("method")["matcher_ms_median"].median()
            text += "\n* median over conditions of the median matcher time: " + ", ".join(
                f"`{m}` {med[m]:.1f} ms" for m in methods if m in med) + "\n"
    else:
        text += "\n" + "".join(f"* {v.detail}\n" for v in found)
        if claim.kind in ("shortlist", "literal"):
            text += "".join(f"* {_identified(labels, m)}\n"
                            for m in ("radial_patch", "radial_paper_patch", "sss_patch")
                            if m in set(labels["method"]))
    return text + f"\n**Verdict: {word}**.\n"


def claims_text(t, labels, paired, ours) -> str:
    out = ["### Every claim and its verdict\n\nEach test compares `a` with `b` on the same "
           "frames, per condition and pooled (\"a only / b only\": the frames where one "
           "succeeds and the other does not; for counts and times, where one's value beats "
           "the other's: a sign test); verdicts by the rules at the top of this page, the "
           f"closest condition to the paper's being {_radial_claims.CLOSEST}. A claim of "
           "fewer misidentified stars carries the stars labelled right beside it (\"as "
           "good\"). The translations are ours.\n\n"]
    for k, c in enumerate(CLAIMS, 1):
        out.append(f"#### C{k}. {c.where}\n\n> 「{c.original}」\n\n*Translation (ours):* "
                   f"\"{c.english}\"\n" + _evidence(c, t, labels, paired, ours) + "\n")
    return "".join(out)


def _paired_table(paired: pd.DataFrame) -> str:
    p = paired[paired["condition"] == -1].copy()
    p["p_text"] = p["p"].map(format_p)
    return fmt_table(p, [("measure", "measure", None), ("A", "a", None), ("B", "b", None),
                         ("units", "frames", None), ("A ok", "a_ok", None),
                         ("B ok", "b_ok", None), ("only A", "only_a", None),
                         ("only B", "only_b", None), ("p", "p_text", None)])


def _arcsec_per_px() -> float:
    """The preset camera's scale at the principal point."""
    from startrack.simulate import load_config

    camera = load_config(Path(__file__).resolve().parents[2] / "configs"
                         / "radial_triangles.toml").camera
    return float(np.degrees(1.0 / camera.f_px) * 3600.0)


def section(folder: Path, run: dict) -> str:
    """The markdown of the section (the renderer writes its title)."""
    read = {n: pd.read_csv(folder / f"{n}.csv") for n in run["tables"]}
    t, labels, paired = read["table"], read["labels"], read["paired"]
    t["correct_ci"] = _ci(t["correct"], t["frames"])
    t["raw_ci"] = _ci(t["first_right"], t["raw_frames"])
    labels = labels.assign(recall=labels["right"] / labels["real"].where(labels["real"] > 0),
                           precision=labels["right"]
                           / labels["identified"].where(labels["identified"] > 0))
    intro = (f"configs/radial_triangles.toml (the paper's camera: 4 x 4 deg, 4096 x 4096 "
             f"px of 9 um, {_arcsec_per_px():.2f} arcsec per pixel at the centre; "
             f"Hipparcos Hp <= 8, {run['view_mean']:.1f} stars in view on average, "
             f"{run['view_min']} to {run['view_max']}), simulated centroids over "
             f"a full grid of centroid noise x false stars. Verified: {run['frames']} "
             f"frames per condition; raw: the first {run['raw_frames']}; every star "
             f"labelled: the first {run['label_frames']}. Lost in space unless the name "
             f"ends in `_patch` (a known 4 deg patch around the true boresight, as the "
             f"paper's navigation stars of the field). Stage times: " + ", ".join(
                 f"{k} {v:.0f} s" for k, v in run.get("seconds", {}).items()) + ".\n\n")
    return (run_block(run, "scripts/papers/radial_features.py") + "\n" + intro + METHOD
            + claims_text(t, labels, paired, read["our_tables"])
            + "### Paired tests, pooled over all conditions\n\n"
            + f"```\n{_paired_table(paired)}\n```\n\n"
            + "Per condition: `docs/data/radial-features/paired.csv`.\n\n"
            + "### Misidentified stars per image (the paper's Figure 6)\n\n"
            + "Every misidentification count beside the stars labelled right: `recall` "
              "(right over the real stars) and `precision` (right over the stars "
              "labelled).\n\n"
            + f"```\n{fmt_table(labels, LABEL_COLUMNS + RATES)}\n```\n\n"
            + "![misidentified stars per image](figures/radial_features_misid.png)\n\n"
            + "### Verified and raw, every condition\n\n"
            + f"```\n{fmt_table(t, BENCH_COLUMNS)}\n```\n\n{LEGEND}\n"
            + paper_tables_text(read["paper_tables"]) + our_tables_text(read["our_tables"]))


def summary(folder: Path, run: dict) -> str:
    """One sentence for the README: each claim's verdict, as the section gives it (the
    same words, grouped by scripts/papers/_verdicts.py)."""
    read = {n: pd.read_csv(folder / f"{n}.csv") for n in run["tables"]}
    words = [(f"{c.short} (C{k})", claim_verdicts(c, read["table"], read["paired"],
                                                  read["our_tables"])[0])
             for k, c in enumerate(CLAIMS, 1)]
    return (f"{len(CLAIMS)} claims quoted in full, judged on {run['frames']} verified, "
            f"{run['raw_frames']} raw and {run['label_frames']} every-star frames per "
            f"condition: {_verdicts.roll_up(words)}")
