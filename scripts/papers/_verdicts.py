"""The verdict rules of docs/results.md, written once: every claim of both papers is judged
by :func:`judge_test` and :func:`judge_claim` from its paired tests' rows, and the README's
roll-up counts the same words (:func:`roll_up`), so the two cannot disagree.

A test compares method ``a`` with method ``b`` frame by frame in each condition of its
scope (exact McNemar, or the exact sign test for counts and times: the same binomial on
the frames where the two differ) and pooled over them. :data:`RULES` is the text the page
opens with; the functions below are that text as code.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

#: a difference is called significant below this two-sided p-value (after Holm's
#: correction for the per-condition tests)
ALPHA = 0.05
REPRODUCED = "reproduced"
ONLY_UNDER = "reproduced only under"
NOT_REPRODUCED = "not reproduced"
REVERSED = "reversed"
NOT_TESTABLE = "not testable here"
#: every verdict word, in the order the README lists them
WORDS = (REPRODUCED, ONLY_UNDER, NOT_REPRODUCED, REVERSED, NOT_TESTABLE)

RULES = f"""\
## How a claim is judged

Every claim below is judged by one function (`scripts/papers/_verdicts.py`, held to made-up
tables by `tests/papers/test_verdicts.py`) from paired tests: two methods on the same frames,
frame by frame (exact McNemar; for counts and times the exact sign test), in each
condition of the test's scope and pooled over them. The per-condition p-values of a test
are corrected together by Holm's method; significant means p < {ALPHA:g} (Holm-corrected
per condition, uncorrected pooled). A test's verdict is one of:

* **{REPRODUCED}**: the pooled test is significant in the claimed direction, no
  condition is significant the other way, and the claim holds (significantly) in the
  condition(s) closest to the paper's stated setting, which each test names.
* **{ONLY_UNDER} X**: significant in the claimed direction in the named conditions X,
  and the pooled test is not significant the other way. The README never counts these
  as reproduced.
* **{REVERSED}**: the pooled test is significant the other way.
* **{NOT_REPRODUCED}**: none of the above.
* **{NOT_TESTABLE}**: our variant satisfies the claim by construction (the verdict says
  what would test it).

A test "as good" (the claim that `a` is no worse than `b`, e.g. the share of stars
labelled right beside a count of misidentified stars) is *{REPRODUCED}* unless `b` is
significantly better pooled (*{REVERSED}*) or in some condition (*{NOT_REPRODUCED}*).
A claim made of several tests is *{REPRODUCED}* when every testable test is,
*{REVERSED}* when any test is, *{ONLY_UNDER}* the named tests and conditions when some
test holds at least in part, *{NOT_TESTABLE}* when no test is testable, else
*{NOT_REPRODUCED}*. A claim of fewer misidentified stars is always judged with a test of
the stars labelled right beside it ("as good"), so that a method labelling nothing
cannot win it.
"""


@dataclass(frozen=True)
class Verdict:
    """A verdict word and what it rests on (``detail``, one clause)."""

    word: str
    detail: str

    def __post_init__(self) -> None:
        if self.word not in WORDS:
            raise ValueError(f"unknown verdict {self.word!r}")


def holm(p: Sequence[float]) -> np.ndarray:
    """Holm's step-down adjusted p-values, in the order given (monotone, at most 1)."""
    p = np.asarray(p, dtype=np.float64)
    m = len(p)
    if m == 0:
        return p.copy()
    order = np.argsort(p, kind="stable")
    adjusted = np.maximum.accumulate(np.minimum((m - np.arange(m)) * p[order], 1.0))
    out = np.empty(m)
    out[order] = adjusted
    return out


def _named(labels: Iterable[str], every: Sequence[str]) -> str:
    """The conditions ``labels`` among ``every``, named; "all but ..." when shorter."""
    picked = [c for c in every if c in set(labels)]
    if len(picked) == len(every):
        return f"all {len(every)} conditions"
    if len(picked) > len(every) / 2:
        rest = [c for c in every if c not in set(picked)]
        return f"{len(picked)} of {len(every)} conditions, all but " + ", ".join(rest)
    return ", ".join(picked)


def judge_test(conditions: pd.DataFrame, pooled, sense: str = "better",
               closest: Sequence[str] = (), construction: str = "") -> Verdict:
    """One test's verdict under :data:`RULES`.

    Parameters
    ----------
    conditions : pandas.DataFrame
        One row per condition: ``condition`` (its label), ``only_a`` and ``only_b`` (the
        frames where one method succeeds and the other does not), ``p`` (exact, two-sided,
        uncorrected); Holm's correction is applied here.
    pooled : mapping
        ``only_a``, ``only_b`` and ``p`` of the test pooled over the conditions.
    sense : str
        "better" (``a`` is claimed better than ``b``) or "as good" (no worse).
    closest : sequence of str
        The condition labels closest to the paper's stated setting.
    construction : str
        Non-empty when the variant satisfies the claim by construction: what would test it.
    """
    if construction:
        return Verdict(NOT_TESTABLE, construction)
    every = list(conditions["condition"])
    adjusted = holm(conditions["p"].to_numpy())
    a_wins = conditions["only_a"].to_numpy() > conditions["only_b"].to_numpy()
    b_wins = conditions["only_b"].to_numpy() > conditions["only_a"].to_numpy()
    a_sig = [c for c, q, w in zip(every, adjusted, a_wins, strict=True) if q < ALPHA and w]
    b_sig = [c for c, q, w in zip(every, adjusted, b_wins, strict=True) if q < ALPHA and w]
    pooled_a = pooled["p"] < ALPHA and pooled["only_a"] > pooled["only_b"]
    pooled_b = pooled["p"] < ALPHA and pooled["only_b"] > pooled["only_a"]
    reverse = f"; the reverse at {_named(b_sig, every)}" if b_sig else ""
    if pooled_b:
        return Verdict(REVERSED, "pooled, the second is significantly better" + reverse)
    if sense == "as good":
        if b_sig:
            return Verdict(NOT_REPRODUCED, f"the second is significantly better at "
                                           f"{_named(b_sig, every)}")
        return Verdict(REPRODUCED, "the second is significantly better nowhere")
    missing = [c for c in closest if c not in a_sig]
    if pooled_a and not b_sig and closest and not missing:
        return Verdict(REPRODUCED, f"significant in {len(a_sig)} of {len(every)} conditions"
                                   f", the closest to the paper's ({', '.join(closest)}) "
                                   "among them")
    if a_sig:
        unmet = (f"; not at the closest to the paper's ({', '.join(missing)})"
                 if missing else "")
        return Verdict(ONLY_UNDER, _named(a_sig, every) + reverse + unmet)
    if pooled_a:
        return Verdict(NOT_REPRODUCED, "significant pooled, in no condition alone after "
                                       "Holm" + reverse)
    if b_sig:
        return Verdict(NOT_REPRODUCED, "no significant difference pooled" + reverse)
    return Verdict(NOT_REPRODUCED, "no significant difference")


def judge_count(holds: dict[str, bool], closest: Sequence[str], what: str) -> Verdict:
    """The verdict of a claim about a count, not a comparison (e.g. "hundreds of answers
    per triangle"): ``holds`` says per condition label whether the count meets the
    claim; read as :func:`judge_test` reads significant conditions, with no pooled test."""
    every = list(holds)
    met = [c for c in every if holds[c]]
    missing = [c for c in closest if not holds.get(c, False)]
    if met and not missing and len(met) == len(every):
        return Verdict(REPRODUCED, f"{what} in every condition")
    if met:
        unmet = (f"; not at the closest to the paper's ({', '.join(missing)})"
                 if missing else "")
        return Verdict(ONLY_UNDER, f"{what} at {_named(met, every)}" + unmet)
    return Verdict(NOT_REPRODUCED, f"{what} in no condition")


def judge_claim(words: Sequence[str]) -> str:
    """A claim's word from its tests' words under :data:`RULES` ("" when it has none)."""
    if not len(words):
        return ""
    unknown = set(words) - set(WORDS)
    if unknown:
        raise ValueError(f"unknown verdicts {sorted(unknown)}")
    testable = [w for w in words if w != NOT_TESTABLE]
    if not testable:
        return NOT_TESTABLE
    if REVERSED in testable:
        return REVERSED
    if all(w == REPRODUCED for w in testable):
        return REPRODUCED
    if any(w in (REPRODUCED, ONLY_UNDER) for w in testable):
        return ONLY_UNDER
    return NOT_REPRODUCED


def roll_up(claims: Sequence[tuple[str, str]]) -> str:
    """The README's sentence on one paper: its (claim label, word) pairs grouped by word,
    in :data:`WORDS` order; "reproduced only under" is said never to count as
    reproduced."""
    groups: dict[str, list[str]] = {}
    for label, word in claims:
        if word:
            groups.setdefault(word, []).append(label)
    parts = []
    for word in WORDS:
        if word in groups:
            head = (f"{word} named conditions (not counted as reproduced)"
                    if word == ONLY_UNDER else word)
            parts.append(f"{len(groups[word])} {head}: " + ", ".join(groups[word]))
    return "; ".join(parts)
