"""The verdict rules (scripts/papers/_verdicts.py) held to made-up tables: the one function that
judges both papers' claims, and the README's roll-up made from its words."""


import numpy as np
import pandas as pd
import pytest

from scripts.papers import _verdicts as v  # noqa: E402


def _table(rows):
    """Conditions "c0", "c1", ... from (only_a, only_b, p) triples."""
    return pd.DataFrame([{"condition": f"c{k}", "only_a": a, "only_b": b, "p": p}
                         for k, (a, b, p) in enumerate(rows)])


def _pooled(a, b, p):
    return {"only_a": a, "only_b": b, "p": p}


def test_holm_matches_the_step_down_by_hand():
    # sorted 0.01, 0.02, 0.04 -> 0.03, 0.04, 0.04 (monotone), in the given order
    assert np.allclose(v.holm([0.04, 0.01, 0.02]), [0.04, 0.03, 0.04])
    assert np.allclose(v.holm([0.5, 0.6]), [1.0, 1.0])
    assert len(v.holm([])) == 0


def test_a_pooled_reversal_is_reversed_whatever_the_conditions_say():
    # the claimed direction wins two conditions, the pooled test goes the other way
    table = _table([(30, 0, 1e-9), (28, 1, 1e-7), (0, 200, 1e-40), (0, 150, 1e-30)])
    verdict = v.judge_test(table, _pooled(58, 351, 1e-50), closest=["c0"])
    assert verdict.word == v.REVERSED
    assert "c2" in verdict.detail and "c3" in verdict.detail


def test_by_construction_is_not_testable_and_says_what_would_test_it():
    table = _table([(100, 0, 1e-30), (100, 0, 1e-30)])
    verdict = v.judge_test(table, _pooled(200, 0, 1e-60), closest=["c0"],
                           construction="built without a pivot: a pivoting variant would")
    assert verdict.word == v.NOT_TESTABLE and "pivoting variant" in verdict.detail
    assert v.judge_claim([v.NOT_TESTABLE]) == v.NOT_TESTABLE
    assert v.judge_claim([v.NOT_TESTABLE, v.REPRODUCED]) == v.REPRODUCED


def test_partial_is_only_under_the_named_conditions_and_never_counted_reproduced():
    table = _table([(40, 0, 1e-12), (3, 2, 1.0), (2, 3, 1.0)])
    verdict = v.judge_test(table, _pooled(45, 5, 1e-9), closest=["c1"])
    assert verdict.word == v.ONLY_UNDER
    assert verdict.detail.startswith("c0") and "not at the closest" in verdict.detail
    said = v.roll_up([("C1 x", v.ONLY_UNDER), ("C2 y", v.REPRODUCED)])
    assert "1 reproduced: C2 y" in said
    assert "not counted as reproduced): C1 x" in said


def test_reproduced_needs_the_closest_condition_and_no_reverse():
    table = _table([(40, 0, 1e-12), (35, 1, 1e-9)])
    assert v.judge_test(table, _pooled(75, 1, 1e-20), closest=["c0"]).word == v.REPRODUCED
    # a significant reverse in one condition (Holm) keeps it "only under"
    table = _table([(40, 0, 1e-12), (35, 1, 1e-9), (0, 30, 1e-9)])
    verdict = v.judge_test(table, _pooled(75, 31, 1e-5), closest=["c0"])
    assert verdict.word == v.ONLY_UNDER and "the reverse at c2" in verdict.detail
    # no closest named: never "reproduced"
    table = _table([(40, 0, 1e-12)])
    assert v.judge_test(table, _pooled(40, 0, 1e-12)).word == v.ONLY_UNDER


def test_holm_decides_a_condition_that_alone_would_pass():
    # p = 0.02 in one of 5 conditions: significant alone, not after Holm (0.1)
    table = _table([(9, 1, 0.02), (2, 2, 1.0), (2, 2, 1.0), (2, 2, 1.0), (2, 2, 1.0)])
    verdict = v.judge_test(table, _pooled(17, 9, 0.17), closest=["c0"])
    assert verdict.word == v.NOT_REPRODUCED and verdict.detail == "no significant difference"


def test_as_good_fails_where_the_second_is_better():
    calm = _table([(2, 3, 1.0), (3, 2, 1.0)])
    assert v.judge_test(calm, _pooled(5, 5, 1.0), "as good").word == v.REPRODUCED
    worse = _table([(0, 40, 1e-12), (3, 2, 1.0)])
    assert v.judge_test(worse, _pooled(3, 42, 1e-9), "as good").word == v.REVERSED
    assert v.judge_test(worse, _pooled(20, 42, 0.2), "as good").word == v.NOT_REPRODUCED


def test_silence_cannot_win_a_misidentification_claim():
    """A method that labels nothing has fewer misidentified stars; the stars labelled
    right beside it reverse the claim."""
    fewer_misid = v.judge_test(_table([(70, 0, 1e-20)]), _pooled(70, 0, 1e-20),
                               closest=["c0"])
    labelled_right = v.judge_test(_table([(0, 1200, 1e-300)]), _pooled(0, 1200, 1e-300),
                                  "as good")
    assert fewer_misid.word == v.REPRODUCED
    assert v.judge_claim([fewer_misid.word, labelled_right.word]) == v.REVERSED


def test_claim_words_combine_by_the_written_rule():
    assert v.judge_claim([]) == ""
    assert v.judge_claim([v.REPRODUCED, v.REPRODUCED]) == v.REPRODUCED
    assert v.judge_claim([v.REPRODUCED, v.ONLY_UNDER]) == v.ONLY_UNDER
    assert v.judge_claim([v.NOT_REPRODUCED, v.ONLY_UNDER]) == v.ONLY_UNDER
    assert v.judge_claim([v.REPRODUCED, v.REVERSED]) == v.REVERSED
    assert v.judge_claim([v.NOT_REPRODUCED, v.NOT_REPRODUCED]) == v.NOT_REPRODUCED
    with pytest.raises(ValueError):
        v.judge_claim(["reproduced only at"])
    with pytest.raises(ValueError):
        v.Verdict("partly", "")


def test_a_count_claim_needs_every_condition_and_the_closest():
    every = {"0 px": False, "1 px": True, "2 px": True}
    verdict = v.judge_count(every, ["0 px"], "median at least 100")
    assert verdict.word == v.ONLY_UNDER and "not at the closest" in verdict.detail
    assert v.judge_count({"0 px": True}, ["0 px"], "x").word == v.REPRODUCED
    assert v.judge_count({"0 px": False}, ["0 px"], "x").word == v.NOT_REPRODUCED
