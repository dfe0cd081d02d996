"""Every claim of the radial-features paper, quoted in full (Chinese, as the stored text
has it, with an English translation of ours), and the paired tests that judge it by the
rules of scripts/papers/_verdicts.py.

The quotes are the paper's sentences character for character (its full-width letters
and digits kept); the extraction of the stored text lost the fraction bar of "3/4" in
equation 4 (it reads "３４"), restored here in brackets: "[３/４]".
"""

from __future__ import annotations

from dataclasses import dataclass

import pandas as pd

from scripts.papers import _verdicts

#: the restoration the quotes carry, and what the stored text has in its place
RESTORED = {"[３/４]": "３４"}
#: the condition closest to the paper's stated setting (ground images of one sky patch:
#: the least centroid noise of the grid, no false star)
CLOSEST = "0.1 px/0 false"
#: the paper's setting: its baseline and its method within a known patch
PATCH_PAIRS = (("radial_patch", "sss_patch"), ("radial_patch", "sss_paper_patch"))
LOST_PAIR = (("radial", "sss"),)


@dataclass(frozen=True)
class Test:
    """``a`` is claimed better than ``b`` on ``measure`` (a measure of
    scripts/papers/_radial_paired.py), or no worse ("as good")."""

    measure: str
    a: str
    b: str
    sense: str = "better"


def _misid_tests(measure: str = "fewer misidentified stars") -> tuple[Test, ...]:
    """A claim of fewer misidentified stars, lost in space and in the paper's setting,
    each with the stars labelled right beside it: a method that labels nothing must not
    win it."""
    pairs = (("radial", "sss"), ("radial_patch", "sss_patch"))
    return tuple(t for a, b in pairs for t in (
        Test(measure, a, b), Test("more stars labelled right", a, b, "as good")))


MISID = _misid_tests() + tuple(Test("verified correct", a, b)
                               for a, b in LOST_PAIR + PATCH_PAIRS)
FASTER = tuple(Test("matcher faster", a, b) for a, b in LOST_PAIR + PATCH_PAIRS)


@dataclass(frozen=True)
class Claim:
    """A claim: where it stands, its sentence (original and English) and how it is
    judged: ``tests`` (paired), or ``kind`` for a claim no two methods decide."""

    where: str
    short: str
    original: str
    english: str
    kind: str
    tests: tuple[Test, ...] = ()


CLAIMS = (
    Claim("Abstract",
          "accuracy and specificity improved",
          "实验结果表明，采用基于径向特征的改进三角形识别算法，星图识别的准确性和针对性都得到了提高。",
          "The experimental results show that with the improved triangle identification "
          "algorithm based on radial features, both the accuracy and the specificity of "
          "star identification are improved.",
          "misid", MISID),
    Claim("Abstract",
          "a few candidates per star",
          "通过星点的几何分布构建星点的径向特征量，依据径向特征量对星图进行初始识别，将拍摄星点的识别结果"
          "限定在数颗导航星上。",
          "A radial feature is built for each star from the stars' geometric distribution; "
          "an initial identification by the radial features restricts the identity of each "
          "photographed star to a few navigation stars.",
          "shortlist"),
    Claim("Section 1.1, equation 4",
          "l >= 3/4 Nq",
          "通过ｌ值进行初始识别，当ｌ值越大时，表示导航星与观测星之间的几何分布相似度越高，可能为一对识别结果。"
          "本文设定ｌ≥[３/４]Ｎｑ时为一对初始识别结果。",
          "The initial identification uses l: the larger l, the more alike the geometric "
          "distributions of the navigation star and the observed star, and the likelier "
          "they are a pair. This paper takes l >= 3/4 Nq as an initial identification pair.",
          "literal"),
    Claim("Section 1.1",
          "efficiency raised",
          "在此基础上再进行三角形星图识别时不再需要遍历导航星，这样将大大减小冗余匹配，使星图识别更具有针对性，"
          "提高星图识别的效率。",
          "The triangle identification that follows no longer needs to go through all "
          "navigation stars, which greatly reduces redundant matching, makes the "
          "identification more specific and raises its efficiency.",
          "time", FASTER),
    Claim("Section 1.2",
          "computation reduced",
          "由以上分析可知，采用基于径向特征的改进三角形进行星图识别时，不再需要遍历所有的导航星，"
          "这样使星点识别更具针对性，同时减少了计算量。",
          "From the above analysis, the improved triangle method based on radial features "
          "no longer needs to go through every navigation star, which makes the "
          "identification more specific and at the same time reduces the computation.",
          "time", FASTER),
    Claim("Section 2, Table 3",
          "the triangle step reduces misidentification",
          "从表３可以看出，对初始识别的结果再次进行识别时，能够有效减少误识别的可能性，使识别结果更具有针对性。",
          "Table 3 shows that identifying the initial identification's results again "
          "effectively reduces the chance of misidentification and makes the result more "
          "specific.",
          "tables"),
    Claim("Section 2, Table 4",
          "plain triangles give one star to two",
          "直接采用三角形星图识别算法对该幅星图进行识别时，在识别的结果中存在着误识别的星点数据。"
          "此时存在着不同的观测星点对应同一颗导航星的现象，部分误识别数据如表４所示。",
          "When the triangle algorithm is applied directly to this star image, its result "
          "contains misidentified stars: different observed stars are matched to the same "
          "navigation star; Table 4 shows part of the misidentified data.",
          "duplicates", _misid_tests("no star given twice")),
    Claim("Section 2, Figure 6",
          "fewer misidentified stars than plain triangles",
          "显然，从图６可以看出，相较于三角形星图识别算法而言，基于径向特征的改进三角形星图识别算法减少了对"
          "星点的误识别，提高了星图识别的正确性。",
          "Clearly, Figure 6 shows that, compared with the triangle algorithm, the improved "
          "triangle algorithm based on radial features reduces the misidentification of "
          "stars and improves the correctness of star identification.",
          "misid", MISID),
    Claim("Conclusion",
          "redundant matching and misidentification overcome",
          "本文引入了星点分布的径向特征量进行初始识别，并在此基础上进行三角形识别，使星图识别的准确性和针对性"
          "都得到了提高，克服了三角形星图识别算法存在冗余匹配与误识别的不足。",
          "This paper introduces radial features of the star distribution for an initial "
          "identification followed by triangle identification, which improves the accuracy "
          "and specificity of star identification and overcomes the redundant matching and "
          "misidentification of the triangle algorithm.",
          "misid", MISID),
)


def _label(row) -> str:
    return f"{row.noise_px:g} px/{int(row.false_stars)} false"


def test_rows(paired: pd.DataFrame, test: Test) -> tuple[pd.DataFrame, pd.Series] | None:
    """(per-condition rows with a ``condition`` label, pooled row) of one test in
    ``paired.csv``; None when a method was not run."""
    rows = paired[(paired["measure"] == test.measure) & (paired["a"] == test.a)
                  & (paired["b"] == test.b)]
    pooled = rows[rows["condition"] == -1]
    if pooled.empty:
        return None
    cond = rows[rows["condition"] >= 0].sort_values("condition")
    cond = cond.assign(condition=[_label(r) for r in cond.itertuples()])
    return cond, pooled.iloc[0]


def judge(paired: pd.DataFrame, test: Test) -> _verdicts.Verdict:
    """One test's verdict (scripts/papers/_verdicts.py); the closest condition is
    :data:`CLOSEST`."""
    found = test_rows(paired, test)
    if found is None:
        return _verdicts.Verdict(_verdicts.NOT_REPRODUCED, f"not run (`{test.a}` or "
                                                           f"`{test.b}` missing)")
    cond, pooled = found
    return _verdicts.judge_test(cond, pooled, test.sense, [CLOSEST])


def shortlist_verdict(table: pd.DataFrame, kind: str) -> _verdicts.Verdict:
    """C2 (a few candidates per star) and C3 (l >= 3/4 Nq gives the initial pairs), from
    the mean shortlists: ours (``radial_patch``) and the paper's rule
    (``radial_paper_patch``), in the paper's setting."""
    short = table.groupby("method")["shortlist_mean"].mean() \
        if "shortlist_mean" in table else pd.Series(dtype=float)
    ours, literal = short.get("radial_patch", 0.0), short.get("radial_paper_patch", 0.0)
    numbers = (f"mean shortlist per star `radial_patch` {ours:.2f}, `radial_paper_patch` "
               f"{literal:.2f}")
    if kind == "literal":
        if literal > 0:
            return _verdicts.Verdict(_verdicts.REPRODUCED, numbers)
        return _verdicts.Verdict(_verdicts.NOT_REPRODUCED, "a star with k neighbours sets "
                                 "at most k rings, so l >= 3/4 Nq needs k >= 3/4 R/dr; with "
                                 "R and dr from equation 3 the paper's rule shortlists no "
                                 "catalog star for any star here: " + numbers)
    if literal > 0:
        return _verdicts.Verdict(_verdicts.REPRODUCED, numbers)
    if ours > 0:
        return _verdicts.Verdict(_verdicts.ONLY_UNDER, "our threshold (l over the rings "
                                 "the star occupies, ring edges tolerant of noise); the "
                                 "paper's rule shortlists nothing: " + numbers)
    return _verdicts.Verdict(_verdicts.NOT_REPRODUCED, numbers)
