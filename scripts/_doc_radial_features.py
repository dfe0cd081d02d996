"""The radial-features paper's section of docs/results.md, from docs/data/radial-features/
(saved by scripts/radial_features.py): every claim with its verdict, then the tables."""

from __future__ import annotations

import re
from pathlib import Path

import pandas as pd
from _radial_claims import CLAIMS, paired_verdict
from _radial_plot import LABEL_COLUMNS
from _radial_tables_doc import our_tables_text, paper_tables_text
from _results_doc import fmt_table, run_block

from startrack.bench.stats import format_p, format_rate, wilson

BENCH_COLUMNS = [("noise", "noise_px", "{:g}"), ("false", "false_stars", None),
                 ("method", "method", None), ("n", "frames", None),
                 ("correct [95%]", "correct_ci", None), ("wrong", "wrong", None),
                 ("raw_n", "raw_frames", None), ("raw1_right [95%]", "raw_ci", None),
                 ("raw_none", "none", None), ("raw1_wrong", "first_wrong_frames", None),
                 ("dup", "duplicates", None), ("t_bench", "time_median_ms", "{:.1f}"),
                 ("t_seq", "seq_ms_median", "{:.1f}"),
                 ("p95", "seq_ms_p95", "{:.1f}"), ("t_match", "matcher_ms_median", "{:.1f}"),
                 ("cand", "cand_median", "{:.0f}"), ("short", "shortlist_mean", "{:.1f}")]
METHOD = """\
**What is compared.** The paper's baseline is the classic side-side-side triangle test
(its equation 5) over every navigation star: `sss` (lost in space, through the catalog's
pair table) and `sss_patch` (the catalog stars of the known patch). The improved method
is the same test over each star's radial shortlist: ours, `radial` and `radial_patch`
(R from the catalog density, rings a few noise sigmas wide, l over the rings the observed
star occupies, ring edges tolerant of noise, at most 10 candidates), and the paper's as
written, `radial_paper` and `radial_paper_patch` (R and dr the largest and smallest
separation among the observed and the navigation stars, l >= 3/4 Nq over every ring,
bits as measured; at most 50 candidates, a bound on memory). `triangle` is our planar
triangle matcher, a different method, shown for scale.

**Every star identified** (the paper's Figures 5 and 6, Tables 3 and 4): each observed
star forms triangles with pairs of its 4 nearest observed stars; a triangle matching
exactly one catalog triangle votes for its three stars' identities; a star takes the
catalog star with the most votes, none on a tie (`startrack/bench/star_labels.py`).
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
        return f"`{method}` not run"
    return (f"`{method}` identifies {format_rate(int(r['identified'].sum()), int(r['real'].sum()))}"
            f" of the real stars, {int(r['misidentified'].sum())} misidentified "
            f"({int(r['false_labelled'].sum())} of them false stars)")


SETTINGS = {"radial": "lost in space", "radial_patch": "in the paper's setting, a known patch"}


def _misid(pairs, labels, paired) -> list[str]:
    lines = [f"Every star labelled, {SETTINGS.get(a, a)}: "
             + paired_verdict(paired, "no misidentified star", a, b) + "; "
             + _identified(labels, a) + "; " + _identified(labels, b) for a, b in pairs]
    return lines + [f"After the shared verification, {SETTINGS.get(a, a)}: "
                    + paired_verdict(paired, "verified correct", a, b) for a, b in pairs]


def _shortlist(claim, t, labels) -> list[str]:
    short = t.groupby("method")["shortlist_mean"].mean() if "shortlist_mean" in t else {}
    ours, literal = ("radial_patch", "radial_paper_patch")
    if claim.kind == "literal":
        head = ("**not reproduced**: a star with k neighbours sets at most k rings, so "
                "l >= 3/4 Nq needs k >= 3/4 R/dr; with R and dr from equation 3 (the "
                "largest and smallest separation) the literal rule's shortlists are empty "
                "for every star here")
    elif ours in short and literal in short and short[ours] > 0 and short[literal] == 0:
        head = ("**reproduced only with our threshold** (l over the rings the star "
                "occupies, ring edges tolerant of noise): the literal rule gives no "
                "candidate at all")
    else:
        head = "**not reproduced**: no shortlists were measured"
    lines = [head] + [_identified(labels, m) for pair in claim.pairs for m in pair]
    return lines + ["mean shortlist per star: " + ", ".join(
        f"`{m}` {short[m]:.2f}" for m in ("radial", ours, literal) if m in short)]


def _table3(ours: pd.DataFrame) -> list[str]:
    t2, t3 = ours[ours["table"] == 2], ours[ours["table"] == 3]
    several = int((t2.groupby("star").size() > 1).sum()) if len(t2) else 0
    doubtful = int((~t2.groupby("star")["true"].all()).sum()) if len(t2) else 0
    given = t3[t3["ra"].notna()]
    wrong = int((~given["true"].astype(bool)).sum())
    if doubtful == 0:
        verdict = ("**not shown on our frame**: the radial step leaves no wrong candidate "
                   "to remove")
    elif wrong < doubtful:
        verdict = "**reproduced on our frame**"
    else:
        verdict = "**not reproduced on our frame**"
    return [f"{verdict}: after the radial step (our Table 2) {several} of the ten brightest "
            f"stars have several candidates and {doubtful} have a wrong one; the "
            f"triangle step (our Table 3) labels {len(given)} stars, {wrong} wrongly. The "
            "per-image counts over every frame are claim 8's"]


def _evidence(claim, t, labels, paired, ours) -> str:
    if claim.kind == "misid":
        lines = _misid(claim.pairs, labels, paired)
    elif claim.kind == "duplicates":
        lines = [f"{SETTINGS.get(a, a)}: "
                 + paired_verdict(paired, "no star given twice", a, b) + "; duplicates "
                 + ", ".join(f"`{m}` {int(labels.loc[labels['method'] == m, 'duplicates'].sum())}"
                             for m in (a, b)) for a, b in claim.pairs]
    elif claim.kind == "time":
        med = t.groupby("method")["matcher_ms_median"].median()
        lines = [f"{SETTINGS.get(a, a)}: " + paired_verdict(paired, "matcher faster", a, b)
                 + (f"; median over conditions of the median matcher time `{a}` "
                    f"{med[a]:.1f} ms, `{b}` {med[b]:.1f} ms" if a in med and b in med
                    else "") for a, b in claim.pairs]
    elif claim.kind in ("shortlist", "literal"):
        lines = _shortlist(claim, t, labels)
    else:
        lines = _table3(ours)
    return "".join(f"   * {line}\n" for line in lines)


def claims_text(t, labels, paired, ours) -> str:
    out = ["### Every claim and its verdict\n\nA verdict's \"A only / B only\" are the "
           "frames where one method succeeds and the other does not (the exact McNemar "
           "test uses only those); \"matcher faster\" is a sign test of the matcher's time "
           "frame by frame.\n\n"]
    for k, c in enumerate(CLAIMS, 1):
        out.append(f"{k}. **C{k}, {c.where}.** 「{c.original}」\n   \"{c.english}\"\n"
                   + _evidence(c, t, labels, paired, ours) + "\n")
    return "".join(out)


def _paired_table(paired: pd.DataFrame) -> str:
    p = paired[paired["condition"] == -1].copy()
    p["p_text"] = p["p"].map(format_p)
    return fmt_table(p, [("measure", "measure", None), ("A", "a", None), ("B", "b", None),
                         ("units", "frames", None), ("A ok", "a_ok", None),
                         ("B ok", "b_ok", None), ("only A", "only_a", None),
                         ("only B", "only_b", None), ("p", "p_text", None)])


def section(folder: Path, run: dict) -> str:
    """The markdown of the section (the renderer writes its title)."""
    read = {n: pd.read_csv(folder / f"{n}.csv") for n in run["tables"]}
    t, labels, paired = read["table"], read["labels"], read["paired"]
    t["correct_ci"] = _ci(t["correct"], t["frames"])
    t["raw_ci"] = _ci(t["first_right"], t["raw_frames"])
    intro = (f"configs/radial_triangles.toml (the paper's camera: 4 x 4 deg, 4096 x 4096 "
             f"px of 9 um; Hipparcos Hp <= 8, {run['view_mean']:.1f} stars in view on "
             f"average, {run['view_min']} to {run['view_max']}), simulated centroids over "
             f"a full grid of centroid noise x false stars. Verified: {run['frames']} "
             f"frames per condition; raw: the first {run['raw_frames']}; every star "
             f"labelled: the first {run['label_frames']}. Lost in space unless the name "
             f"ends in `_patch` (a known 4 deg patch around the true boresight, as the "
             f"paper's navigation stars of the field). Stage times: " + ", ".join(
                 f"{k} {v:.0f} s" for k, v in run.get("seconds", {}).items()) + ".\n\n")
    return (run_block(run, "scripts/radial_features.py") + "\n" + intro + METHOD
            + claims_text(t, labels, paired, read["our_tables"])
            + "### Paired tests, pooled over all conditions\n\n"
            + f"```\n{_paired_table(paired)}\n```\n\n"
            + "Per condition: `docs/data/radial-features/paired.csv`.\n\n"
            + "### Misidentified stars per image (the paper's Figure 6)\n\n"
            + f"```\n{fmt_table(labels, LABEL_COLUMNS)}\n```\n\n"
            + "![misidentified stars per image](figures/radial_features_misid.png)\n\n"
            + "### Verified and raw, every condition\n\n"
            + f"```\n{fmt_table(t, BENCH_COLUMNS)}\n```\n\n{LEGEND}\n"
            + paper_tables_text(read["paper_tables"]) + our_tables_text(read["our_tables"]))


def summary(folder: Path, run: dict) -> str:
    """One sentence for the README: each claim's verdicts (per setting), as the section
    gives them."""
    read = {n: pd.read_csv(folder / f"{n}.csv") for n in run["tables"]}
    said = []
    for k, c in enumerate(CLAIMS, 1):
        text = _evidence(c, read["table"], read["labels"], read["paired"], read["our_tables"])
        parts = []
        for line in text.splitlines():
            found = re.match(r"\s*\* (.*?)\*\*(.+?)\*\*", line)
            if found:
                where = found.group(1).rstrip(": ").lower()
                parts.append(found.group(2) + (f" ({where})" if where else ""))
        said.append(f"C{k} {c.short}: " + "; ".join(parts))
    return (f"{len(CLAIMS)} claims quoted in full, judged on {run['frames']} verified, "
            f"{run['raw_frames']} raw and {run['label_frames']} every-star frames per "
            f"condition ({'. '.join(said)})")
