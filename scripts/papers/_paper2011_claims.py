"""The 2011 triangle-base paper's claims, each quoted in full, and the paired tests that
judge them on the bench's frames (scripts/papers/paper2011.py saves them as claims.csv).

Every test compares two methods on the same frames of the same conditions: per frame an
outcome for each (right or not, answered or not, faster or not, ...), and the exact
McNemar test on the frames where the two differ (for "faster" and "fewer", the exact
sign test: the same binomial). One row per condition of the test's scope and one pooled
row; the verdict (:func:`verdict`, the rules of scripts/papers/_verdicts.py) reads those rows only.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from scripts.papers import _verdicts
from startrack.bench import mcnemar_exact

ALPHA = _verdicts.ALPHA
#: per scope, the condition closest to the paper's stated setting: the paper names no
#: noise level and no false-star count for its claims, so the least of both in the scope
CLOSEST = {"grid": "0 px/0 false", "noise": "0 px/0 false", "false": "0 px/1 false",
           "fov10": "0 px/0 false"}


@dataclass(frozen=True)
class Test:
    """``a`` is claimed better than ``b`` on ``measure`` ("better"), or at least as good
    ("as good": the claim holds unless ``b`` is significantly better somewhere), over the
    conditions of ``scope``: "grid" (every noise x false-star condition), "false" (those
    with false stars), "noise" (no false star), "fov10" (the 10 deg field).
    ``construction``: why the variants meet the claim by construction and what would
    test it ("" when they do not)."""

    measure: str
    a: str
    b: str
    scope: str
    sense: str = "better"
    construction: str = ""


@dataclass(frozen=True)
class Claim:
    key: str
    short: str  # the claim in a few words, for the README
    where: str
    original: str
    english: str  # "" when the original is English
    tests: tuple[Test, ...]
    note: str = ""


#: what each measure's outcome is, per frame (the doc's wording)
MEASURES = {
    "verified": "verified and right (`identify()`, shared verification)",
    "raw_right": "first hypothesis right, unverified (the paper's accuracy)",
    "answers": "yields any hypothesis",
    "faster": "faster identify() on the frame (best of repeats, one process)",
    "fewer_pivots": "fewer pivots on the frame",
    "fewer_candidates": "fewer catalog candidates per lookup (triangle: after the polar "
                        "moment filter; angle: pairs in the window)",
    "no_pivots": "no pivot on the frame",
}

ANGLE_EN = ("A method for narrowing down to one solution involves employing many angles "
            "within the field of view in a certain order, called \u201cpivoting,\u201d which "
            "can be time consuming and does not always yield a solution.")
TRIANGLE_EN = ("By using both the area and polar moment properties of the planar triangle, "
               "the range of possible solutions is very quickly narrowed, fewer pivots to "
               "other planar triangles are required, and the method is more likely to "
               "yield the correct solution than the angle method.")
HYBRID_EN = ("Second, by triangle method in fewer time identification completed, because "
             "FOV is smaller. So this new method is faster than triangle and more accurate "
             "than angle method and we do not pivoting the same as each method.")
FALSE_EN = ("In addition, Simulation results show the performance of the new method as "
            "well as its robustness with respect to including false stars.")
# The Persian sentences, reassembled: the stored text's lines come out in scrambled order
# (right-to-left runs reversed), so the word order is restored by us, every word as the
# text has it (its spellings, no zero-width joiners), one sentence per constant; the page
# says so, and tests/papers/test_paper_quotes.py checks every word against the text. One word
# is split across the text's runs: REASSEMBLED_WORDS.
SPEED_FA = ("اين تركيب باعث افزايش سرعت الگوريتم جستجو نسبت به روش مثلثي مي شود زيرا حجم "
            "محاسبات را بسيار كاهش داده و دقت آن نيز به مراتب نسبت به روش زاويه بالاتر است.")
SPEED_EN = ("This combination makes the search algorithm faster than the triangle method, "
            "because it greatly reduces the amount of computation, and its accuracy is also "
            "far higher than the angle method's.")
FALSE_FA = ("اين روش در مقابل ستاره هاي اشتباه در ميدان ديد نيز مقاومت بيشتري نسبت به "
            "هركدام از روش ها دارد.")
FALSE_FA_EN = ("This method is also more robust against false stars in the field of view "
               "than either of the methods.")
STARS_FA = ("يك نكتة منفي اين روش عدم كارايي آن با كمتر از 3 ستاره در ميدان ديد آن است، در "
            "حالي كه در روش زاويه به دو ستاره نياز است. بعد از خطاي اندازه گيري جستجوگر، "
            "معمولأ بيشتر از دو ستاره در روش زاويه مورد نياز است. چيزي كه مشاهده مي شود "
            "اين است كه در روش مثلثي ستاره هاي مشترك كمتري مورد نياز است كه در نهايت نسبت "
            "به روش زاويه به تعداد كمتري ستاره براي رسيدن به پاسخ صحيح نياز دارد.")
STARS_EN = ("One drawback of this method is that it does not work with fewer than 3 stars in "
            "its field of view, while the angle method needs two stars. After the tracker's "
            "measurement error, usually more than two stars are needed in the angle method. "
            "What is observed is that the triangle method needs fewer shared stars, so that "
            "in the end it needs fewer stars than the angle method to reach the correct "
            "answer.")
HUNDREDS_FA = ("تست هر پاسخ ممكن با مثلث اول به جاي مقايسه با اشتراك، كار زمان بري است كه "
               "صدها پاسخ به ازاي هر مثلث در ميدان ديد وجود دارد. براي كاهش تعداد تركيبات "
               "در 3 تست، درخت تست دودويي ايجاد مي شود.")
#: words of the Persian quotes split across the stored text's runs: the word, and the
#: fragment the text has in its place
REASSEMBLED_WORDS = {"نكتة": "ةيك نكت"}
HUNDREDS_EN = ("Testing each possible answer against the first triangle instead of comparing "
               "by pivoting is time-consuming, since there are hundreds of answers for every "
               "triangle in the field of view. To reduce the number of combinations in 3 "
               "tests, a binary test tree is created.")

NO_PIVOT_BUILT = ("`hybrid_single` is built without a pivot, so it never pivots; what "
                  "tests the claim is a hybrid that may pivot, counted: test 1, our "
                  "`hybrid`, whose fourth-star checks are its pivots")

#: each method's first-hypothesis variant (no pivoting on past its first hypothesis): the
#: paper's raw comparisons are made again between the variants
FIRST_HYPOTHESIS = {"hybrid": "hybrid_single", "triangle": "triangle_first",
                    "angle": "angle_open"}
#: the methods the false-star claims (C6, C7) compare: the hybrid against each
AGAINST_EITHER = (("hybrid", "triangle"), ("hybrid", "angle"))


def tests_of(measure: str, scope: str, pairs) -> tuple[Test, ...]:
    """``measure`` over ``scope`` for each ``(a, b)`` pair of methods, in order."""
    return tuple(Test(measure, a, b, scope) for a, b in pairs)


def with_variants(measure: str, scope: str, pairs) -> tuple[Test, ...]:
    """:func:`tests_of` the pairs, then of their :data:`FIRST_HYPOTHESIS` variants."""
    variants = [(FIRST_HYPOTHESIS[a], FIRST_HYPOTHESIS[b]) for a, b in pairs]
    return tests_of(measure, scope, pairs) + tests_of(measure, scope, variants)


CLAIMS = (
    Claim("C1", "the angle method's pivoting does not always answer",
          "Abstract (English, as printed)", ANGLE_EN, "",
          with_variants("answers", "grid", [("triangle", "angle")])),
    Claim("C2", "triangles narrow faster, pivot less and are right more often than angles",
          "Abstract (English, as printed)", TRIANGLE_EN, "",
          (Test("fewer_candidates", "triangle", "angle", "grid"),
           *with_variants("fewer_pivots", "grid", [("triangle", "angle")]),
           *with_variants("raw_right", "grid", [("triangle", "angle")]))),
    Claim("C3", "the hybrid is faster than the triangle method",
          "Abstract (English, as printed): speed", HYBRID_EN, "",
          (Test("faster", "hybrid", "triangle", "noise"),
           Test("faster", "hybrid", "triangle", "false"),
           Test("faster", "hybrid_single", "triangle_first", "noise"))),
    Claim("C4", "the hybrid is faster than triangles and more accurate than angles",
          "Abstract (Persian): speed and accuracy", SPEED_FA, SPEED_EN,
          (Test("faster", "hybrid", "triangle", "noise"),
           *with_variants("raw_right", "grid", [("hybrid", "angle")]),
           Test("verified", "hybrid", "angle", "grid"))),
    Claim("C5", "the hybrid needs no pivoting",
          "Abstract (English, as printed): no pivoting", HYBRID_EN, "",
          (Test("no_pivots", "hybrid", "triangle", "grid"),
           Test("no_pivots", "hybrid_single", "triangle_first", "grid",
                construction=NO_PIVOT_BUILT),
           Test("raw_right", "hybrid_single", "hybrid", "grid", "as good")),
          note="the last test asks what leaving the pivots out costs"),
    Claim("C6", "the hybrid is robust to false stars",
          "Abstract (English, as printed)", FALSE_EN, "",
          with_variants("raw_right", "false", AGAINST_EITHER)
          + tests_of("verified", "false", AGAINST_EITHER)),
    Claim("C7", "the hybrid is more robust to false stars than either method",
          "Abstract (Persian): false stars", FALSE_FA, FALSE_FA_EN,
          tests_of("raw_right", "false", AGAINST_EITHER)
          + tests_of("verified", "false", AGAINST_EITHER),
          note="C6's tests of ours: the Persian sentence says 'than either' method"),
    Claim("C8", "triangles need fewer stars than angles",
          "Triangle method section (Persian)", STARS_FA, STARS_EN,
          (*with_variants("verified", "fov10", [("triangle", "angle")]),
           Test("verified", "triangle", "angle", "grid"))),
    Claim("C9", "hundreds of catalog triangles per observed one",
          "Triangle method section (Persian)", HUNDREDS_FA, HUNDREDS_EN, (),
          note="no two methods compared: the catalog triangles per lookup are counted"),
)

#: per measure: the per-frame table it is read from and the column
SOURCE = {"verified": ("verified", "correct"), "raw_right": ("raw", "first_right"),
          "answers": ("raw", "yielded"), "faster": ("timing", "seq_ms"),
          "fewer_pivots": ("raw", "pivots"), "no_pivots": ("raw", "pivots"),
          "fewer_candidates": ("raw", "kept_per_lookup")}
KEY = ["condition", "frame"]


def per_lookup(raw: pd.DataFrame) -> pd.Series:
    """Catalog candidates per lookup on each frame: the triangle matcher's after the polar
    moment filter (``x_polar_kept``), the others' (angle pairs) as counted."""
    kept = raw["x_polar_kept"] if "x_polar_kept" in raw else pd.Series(np.nan, raw.index)
    lookups = raw["x_lookups"] if "x_lookups" in raw else pd.Series(np.nan, raw.index)
    found = kept.where(kept.notna(), raw["candidates"])
    return found / lookups.where(lookups > 0)


def outcomes(frames: pd.DataFrame, measure: str, a: str, b: str) -> pd.DataFrame:
    """Per frame of both methods (the frames both have): ``oa``, ``ob`` as booleans, with
    the frame's condition columns."""
    _, col = SOURCE[measure]
    conds = frames.drop_duplicates(KEY).set_index(KEY)[["noise_px", "false_stars"]]
    va = frames[frames["method"] == a].set_index(KEY)[col].rename("va")
    vb = frames[frames["method"] == b].set_index(KEY)[col].rename("vb")
    both = pd.concat([va, vb], axis=1, join="inner").dropna()
    if measure in ("faster", "fewer_pivots", "fewer_candidates"):
        oa, ob = both["va"] < both["vb"], both["vb"] < both["va"]
    elif measure == "no_pivots":
        oa, ob = both["va"] == 0, both["vb"] == 0
    else:
        oa, ob = both["va"].astype(bool), both["vb"].astype(bool)
    out = pd.DataFrame({"oa": oa, "ob": ob})
    wrong = _wrong(frames, measure)
    if wrong is not None:  # beside "right": the frames answered wrongly, per method
        for col, m in (("wa", a), ("wb", b)):
            out[col] = wrong[(frames["method"] == m).to_numpy()].reindex(out.index)
            out[col] = out[col].fillna(False).astype(bool)
    return conds.join(out, how="inner").reset_index()


def _wrong(frames: pd.DataFrame, measure: str) -> pd.Series | None:
    """Per frame row (indexed by condition and frame): answered and wrong (verified:
    accepted but not correct; raw: a first hypothesis that is not right); None for the
    measures with no right or wrong answer."""
    if measure == "verified" and "wrong" in frames:
        wrong = frames["wrong"].astype(bool)
    elif measure == "raw_right" and "yielded" in frames:
        wrong = frames["yielded"].astype(bool) & ~frames["first_right"].astype(bool)
    else:
        return None
    return pd.Series(wrong.to_numpy(), index=pd.MultiIndex.from_frame(frames[KEY]))


def _in_scope(frame: pd.DataFrame, scope: str) -> pd.DataFrame:
    if scope == "false":
        return frame[frame["false_stars"] > 0]
    if scope == "noise":
        return frame[frame["false_stars"] == 0]
    return frame


def paired_rows(claim: Claim, number: int, test: Test, sources: dict) -> list[dict]:
    """The paired test's rows: one per condition of its scope, then the pooled one."""
    source, _ = SOURCE[test.measure]
    frames = sources["fov10" if test.scope == "fov10" else source]
    paired = _in_scope(outcomes(frames, test.measure, test.a, test.b), test.scope)
    groups = [((n, f), g) for (n, f), g in paired.groupby(["noise_px", "false_stars"])]
    groups.append(((np.nan, np.nan), paired))
    rows = []
    for j, ((noise, false), g) in enumerate(groups, start=1):
        res = mcnemar_exact(g["oa"].to_numpy(), g["ob"].to_numpy())
        pooled = j == len(groups)
        rows.append({"row": f"{claim.key}.{number}" + ("" if pooled else f".{j}"),
                     "claim": claim.key, "test": number, "measure": test.measure,
                     "a": test.a, "b": test.b, "scope": test.scope, "sense": test.sense,
                     "condition": "pooled" if pooled else f"{noise:g} px/{int(false)} false",
                     "noise_px": noise, "false_stars": false, "n": res.frames,
                     "k_a": int(g["oa"].sum()), "k_b": int(g["ob"].sum()),
                     "only_a": res.only_a, "only_b": res.only_b, "p": res.p,
                     "wrong_a": int(g["wa"].sum()) if "wa" in g else np.nan,
                     "wrong_b": int(g["wb"].sum()) if "wb" in g else np.nan})
    return rows


def claims_table(sources: dict) -> pd.DataFrame:
    """Every claim's paired tests on the frames in ``sources`` ("verified": the bench's
    frames.csv rows, "raw": the raw pass's, "timing": the timing pass's, "fov10": the
    10 deg field's bench rows), one row per condition and test; the row id is
    claim.test.condition, claim.test for the pooled row."""
    rows = []
    for claim in CLAIMS:
        for number, test in enumerate(claim.tests, start=1):
            part = pd.DataFrame(paired_rows(claim, number, test, sources))
            part["p_holm"] = np.append(_verdicts.holm(part["p"].to_numpy()[:-1]),
                                       part["p"].iloc[-1])  # the pooled row: uncorrected
            part["construction"] = test.construction
            rows.append(part)
    return pd.concat(rows, ignore_index=True)


def verdict(rows: pd.DataFrame) -> tuple[str, str]:
    """(verdict, detail) of one test from its rows (the pooled row last), by the rules of
    scripts/papers/_verdicts.py; the closest condition to the paper's is :data:`CLOSEST`'s."""
    cond, pooled = rows.iloc[:-1], rows.iloc[-1]
    construction = pooled.get("construction", "")
    closest = [c for c in [CLOSEST[pooled["scope"]]] if c in set(cond["condition"])]
    v = _verdicts.judge_test(cond, pooled, pooled["sense"], closest or ["(not run)"],
                             construction if isinstance(construction, str) else "")
    return v.word, v.detail


def claim_verdict(rows: pd.DataFrame) -> str:
    """A claim's verdict from its tests' rows (scripts/papers/_verdicts.py); "" with no test."""
    return _verdicts.judge_claim([verdict(g)[0] for _, g in rows.groupby("test", sort=True)])
