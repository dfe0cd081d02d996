"""Every claim of the radial-features paper, quoted in full (Chinese, with an English
translation), and its verdict computed from the saved tables.

The quotes are the paper's sentences; the extraction of the stored text lost the fraction
bar of "3/4" in equation 4 (it reads "３４"), restored here in brackets.
"""

from __future__ import annotations

from dataclasses import dataclass

import pandas as pd

from startrack.bench.stats import format_p, format_rate


@dataclass(frozen=True)
class Claim:
    """A claim: where it stands, its sentence (original and English) and how it is
    tested (``kind`` picks the evidence, ``pairs`` the methods compared)."""

    where: str
    short: str
    original: str
    english: str
    kind: str
    pairs: tuple[tuple[str, str], ...] = ()


CLAIMS = (
    Claim("Abstract",
          "accuracy and specificity improved",
          "实验结果表明，采用基于径向特征的改进三角形识别算法，星图识别的准确性和针对性都得到了提高。",
          "The experimental results show that with the improved triangle identification "
          "algorithm based on radial features, both the accuracy and the specificity of "
          "star identification are improved.",
          "misid", (("radial", "sss"), ("radial_patch", "sss_patch"))),
    Claim("Abstract",
          "a few candidates per star",
          "通过星点的几何分布构建星点的径向特征量，依据径向特征量对星图进行初始识别，将拍摄星点的识别结果"
          "限定在数颗导航星上。",
          "A radial feature is built for each star from the stars' geometric distribution; "
          "an initial identification by the radial features restricts the identity of each "
          "photographed star to a few navigation stars.",
          "shortlist", (("radial_patch", "radial_paper_patch"),)),
    Claim("Section 1.1, equation 4",
          "l >= 3/4 Nq",
          "通过l值进行初始识别，当l值越大时，表示导航星与观测星之间的几何分布相似度越高，可能为一对识别结果。"
          "本文设定l≥[3/4]Nq时为一对初始识别结果。",
          "The initial identification uses l: the larger l, the more alike the geometric "
          "distributions of the navigation star and the observed star, and the likelier "
          "they are a pair. This paper takes l >= 3/4 Nq as an initial identification pair.",
          "literal", (("radial_paper_patch", "sss_patch"),)),
    Claim("Section 1.1",
          "efficiency raised",
          "在此基础上再进行三角形星图识别时不再需要遍历导航星，这样将大大减小冗余匹配，使星图识别更具有针对性，"
          "提高星图识别的效率。",
          "The triangle identification that follows no longer needs to go through all "
          "navigation stars, which greatly reduces redundant matching, makes the "
          "identification more specific and raises its efficiency.",
          "time", (("radial", "sss"), ("radial_patch", "sss_patch"))),
    Claim("Section 1.2",
          "computation reduced",
          "由以上分析可知，采用基于径向特征的改进三角形进行星图识别时，不再需要遍历所有的导航星，"
          "这样使星点识别更具针对性，同时减少了计算量。",
          "From the above analysis, the improved triangle method based on radial features "
          "no longer needs to go through every navigation star, which makes the "
          "identification more specific and at the same time reduces the computation.",
          "time", (("radial", "sss"), ("radial_patch", "sss_patch"))),
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
          "duplicates", (("radial", "sss"), ("radial_patch", "sss_patch"))),
    Claim("Section 2, Figure 6",
          "fewer misidentified stars than plain triangles",
          "显然，从图６可以看出，相较于三角形星图识别算法而言，基于径向特征的改进三角形星图识别算法减少了对"
          "星点的误识别，提高了星图识别的正确性。",
          "Clearly, Figure 6 shows that, compared with the triangle algorithm, the improved "
          "triangle algorithm based on radial features reduces the misidentification of "
          "stars and improves the correctness of star identification.",
          "misid", (("radial", "sss"), ("radial_patch", "sss_patch"))),
    Claim("Conclusion",
          "redundant matching and misidentification overcome",
          "本文引入了星点分布的径向特征量进行初始识别，并在此基础上进行三角形识别，使星图识别的准确性和针对性"
          "都得到了提高，克服了三角形星图识别算法存在冗余匹配与误识别的不足。",
          "This paper introduces radial features of the star distribution for an initial "
          "identification followed by triangle identification, which improves the accuracy "
          "and specificity of star identification and overcomes the redundant matching and "
          "misidentification of the triangle algorithm.",
          "misid", (("radial", "sss"), ("radial_patch", "sss_patch"))),
)


def _where(row) -> str:
    return f"noise {row.noise_px:g} px, {int(row.false_stars)} false"


def paired_verdict(paired: pd.DataFrame, measure: str, a: str, b: str) -> str:
    """"reproduced" when A beats B pooled over all conditions (exact McNemar p < 0.05),
    "reproduced only at <conditions>" when it does so in some conditions only, else "not
    reproduced" (saying when B is the better one); with the pooled test's numbers."""
    rows = paired[(paired["measure"] == measure) & (paired["a"] == a) & (paired["b"] == b)]
    if rows.empty:
        return f"not run (`{a}` or `{b}` missing)"
    pooled = rows[rows["condition"] == -1].iloc[0]
    evidence = (f"`paired.csv` row ({measure}, all conditions, `{a}` vs `{b}`): `{a}` "
                f"{format_rate(pooled.a_ok, pooled.frames)}, `{b}` "
                f"{format_rate(pooled.b_ok, pooled.frames)}; only `{a}` {pooled.only_a}, "
                f"only `{b}` {pooled.only_b}, McNemar exact p = {format_p(pooled.p)}")
    if pooled.only_a > pooled.only_b and pooled.p < 0.05:
        return f"**reproduced** ({evidence})"
    wins = rows[(rows["condition"] >= 0) & (rows["only_a"] > rows["only_b"])
                & (rows["p"] < 0.05)]
    if not wins.empty:
        where = "; ".join(_where(r) for r in wins.itertuples())
        return f"**reproduced only at** {where} ({evidence})"
    if pooled.only_b > pooled.only_a and pooled.p < 0.05:
        return f"**not reproduced: the opposite holds** ({evidence})"
    return f"**not reproduced** (no difference shown: {evidence})"
