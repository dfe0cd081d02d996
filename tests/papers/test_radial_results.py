"""The radial-features section's paired tests and verdicts (scripts/papers/_radial_paired.py,
scripts/papers/_radial_claims.py): the same frames compared method against method."""


import pandas as pd

from scripts.papers import (
    _radial_claims,  # noqa: E402
    _radial_paired,  # noqa: E402
    _verdicts,  # noqa: E402
)


def _frames(ok_a, ok_b, condition=0):
    rows = []
    for f, (a, b) in enumerate(zip(ok_a, ok_b, strict=True)):
        for method, ok in (("radial", a), ("sss", b)):
            rows.append({"condition": condition, "noise_px": 0.3 * (condition + 1),
                         "false_stars": condition, "frame": f, "method": method,
                         "correct": ok, "first_right": ok, "misidentified": int(not ok),
                         "duplicates": 0, "right": int(ok),
                         "matcher_ms": 1.0 if method == "radial" else 2.0})
    return pd.DataFrame(rows)


def _paired(frames):
    return _radial_paired.paired_tests(frames, frames, frames)


def test_mcnemar_uses_the_discordant_frames_of_each_condition_and_pooled():
    frames = pd.concat([_frames([True] * 12, [False] * 10 + [True] * 2, 0),
                        _frames([True] * 12, [True] * 12, 1)])
    out = _paired(frames)
    row = out[(out["measure"] == "no misidentified star") & (out["condition"] == -1)
              & (out["a"] == "radial") & (out["b"] == "sss")].iloc[0]
    assert (row.only_a, row.only_b, row.frames) == (10, 0, 24)
    assert row.p < 0.01
    calm = out[(out["measure"] == "verified correct") & (out["condition"] == 1)].iloc[0]
    assert (calm.only_a, calm.only_b, calm.p) == (0, 0, 1.0)
    faster = out[out["measure"] == "matcher faster"].iloc[0]
    assert (faster.only_a, faster.only_b) == (24, 0)


def _judge(frames, measure="verified correct", sense="better"):
    test = _radial_claims.Test(measure, "radial", "sss", sense)
    return _radial_claims.judge(_paired(frames), test)


def test_the_verdict_names_the_conditions_where_only_they_hold():
    frames = pd.concat([_frames([True] * 12, [False] * 10 + [True] * 2, 0),
                        _frames([False] * 14, [True] * 14, 1)])
    v = _judge(frames)
    # 10 frames for radial at 0.3 px, 14 for sss at 0.6 px: pooled not significant
    assert v.word == "reproduced only under" and v.detail.startswith("0.3 px/0 false")
    assert "the reverse at 0.6 px/1 false" in v.detail
    assert _judge(_frames([False] * 12, [True] * 12)).word == "reversed"
    assert _judge(_frames([True] * 3, [True] * 3)).word == "not reproduced"


def test_counts_are_compared_frame_by_frame_and_recall_sits_beside_misidentification():
    """A method that labels nothing has no misidentified star and loses on the stars
    labelled right: the claim of fewer misidentified stars is reversed."""
    frames = _frames([True] * 20, [True] * 20)
    frames["misidentified"] = [0 if m == "radial" else f % 2 for f, m in
                               zip(frames["frame"], frames["method"], strict=True)]
    frames["right"] = [0 if m == "radial" else 10 for m in frames["method"]]
    paired = _paired(frames)
    row = paired[(paired["measure"] == "fewer misidentified stars")
                 & (paired["condition"] == -1)].iloc[0]
    assert (row.only_a, row.only_b) == (10, 0)
    fewer = _judge(frames, "fewer misidentified stars")
    right = _judge(frames, "more stars labelled right", "as good")
    assert right.word == "reversed"
    assert _verdicts.judge_claim([fewer.word, right.word]) == "reversed"


def test_every_claim_is_quoted_in_full_with_a_translation():
    for claim in _radial_claims.CLAIMS:
        assert claim.original.endswith("。") and len(claim.english) > 40
        assert claim.kind in ("misid", "shortlist", "literal", "time", "tables", "duplicates")
        assert bool(claim.tests) == (claim.kind in ("misid", "time", "duplicates"))
        if claim.kind in ("misid", "duplicates"):  # recall beside every misid test
            assert any(t.measure == "more stars labelled right" and t.sense == "as good"
                       for t in claim.tests)
