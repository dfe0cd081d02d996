"""The 2011 paper's claim tests (scripts/papers/_paper2011_claims.py): paired outcomes per frame,
one row per condition and a pooled one, and verdicts read from the p-values."""


import numpy as np
import pandas as pd

from scripts.papers import _paper2011_claims as claims  # noqa: E402


def _frames(rates_a, rates_b, n=60, seed=0):
    """Per-frame verified outcomes of methods a and b in two conditions, a right at
    ``rates_a[c]``, b at ``rates_b[c]`` (seeded)."""
    rng = np.random.default_rng(seed)
    rows = []
    for c, (ra, rb) in enumerate(zip(rates_a, rates_b, strict=True)):
        u = rng.random(n)
        for method, rate in (("a", ra), ("b", rb)):
            rows += [{"condition": c, "frame": f, "noise_px": float(c), "false_stars": 0,
                      "method": method, "correct": bool(u[f] < rate)} for f in range(n)]
    return pd.DataFrame(rows)


def _rows(frames, sense="better"):
    claim = claims.Claim("X", "x", "where", "said", "", ())
    test = claims.Test("verified", "a", "b", "grid", sense)
    return pd.DataFrame(claims.paired_rows(claim, 1, test, {"verified": frames}))


def test_rows_per_condition_and_pooled_count_discordant_frames():
    rows = _rows(_frames([0.9, 0.5], [0.5, 0.5]))
    assert list(rows["row"]) == ["X.1.1", "X.1.2", "X.1"]
    pooled = rows.iloc[-1]
    assert pooled["n"] == 120 and pooled["condition"] == "pooled"
    # the same random draw for both methods: b right implies a right
    assert rows.iloc[1]["only_a"] == rows.iloc[1]["only_b"] == 0
    assert pooled["only_a"] == pooled["k_a"] - pooled["k_b"] and pooled["only_b"] == 0


def test_verdicts_follow_the_written_rules():
    """scripts/papers/_verdicts.py's rules on the claims' rows; the closest condition to the
    paper's is 0 px/0 false (the first)."""
    assert claims.verdict(_rows(_frames([0.95, 0.95], [0.3, 0.3])))[0] == "reproduced"
    # holds at the closest condition only: still reproduced (no reverse anywhere)
    assert claims.verdict(_rows(_frames([0.95, 0.5], [0.3, 0.5])))[0] == "reproduced"
    word, detail = claims.verdict(_rows(_frames([0.5, 0.95, 0.5], [0.5, 0.3, 0.5])))
    assert word == "reproduced only under" and detail.startswith("1 px/0 false")
    assert "not at the closest" in detail
    word, detail = claims.verdict(_rows(_frames([0.3, 0.3], [0.95, 0.95])))
    assert word == "reversed" and "reverse" in detail
    assert claims.verdict(_rows(_frames([0.5, 0.5], [0.5, 0.5])))[0] == "not reproduced"
    # "as good": holds unless the second is significantly better
    assert claims.verdict(_rows(_frames([0.5, 0.5], [0.5, 0.5]), "as good"))[0] == \
        "reproduced"
    assert claims.verdict(_rows(_frames([0.3, 0.3], [0.95, 0.95]), "as good"))[0] == \
        "reversed"


def test_a_claim_with_a_reversed_test_is_reversed():
    """The README's C4 said "reproduced under named conditions" while its speed test was
    reversed: a claim is reversed when any of its tests is."""
    good = _rows(_frames([0.95, 0.95], [0.3, 0.3]))
    bad = _rows(_frames([0.3, 0.3], [0.95, 0.95])).assign(test=2)
    assert claims.claim_verdict(pd.concat([good, bad])) == "reversed"
    assert claims.claim_verdict(good) == "reproduced"


def test_a_variant_built_to_meet_the_claim_is_not_testable():
    built = _rows(_frames([0.95, 0.95], [0.3, 0.3])).assign(construction="built so")
    assert claims.verdict(built) == ("not testable here", "built so")
    no_pivot = [t for c in claims.CLAIMS for t in c.tests if t.construction]
    assert [(t.a, t.measure) for t in no_pivot] == [("hybrid_single", "no_pivots")]


def test_wrong_answers_are_counted_beside_the_right_ones():
    frames = _frames([0.9, 0.5], [0.5, 0.5])
    frames["wrong"] = ~frames["correct"] & (frames["frame"] % 2 == 0)
    rows = _rows(frames)
    pooled = rows.iloc[-1]
    expect = frames[frames["method"] == "a"]["wrong"].sum()
    assert pooled["wrong_a"] == expect and pooled["wrong_b"] > 0


def test_faster_compares_times_frame_by_frame():
    rows = [{"condition": 0, "frame": f, "noise_px": 0.0, "false_stars": 0, "method": m,
             "seq_ms": t} for f in range(20) for m, t in (("a", 1.0 + f), ("b", 2.0 + f))]
    out = claims.outcomes(pd.DataFrame(rows), "faster", "a", "b")
    assert out["oa"].all() and not out["ob"].any()


def test_every_claim_quotes_a_sentence_and_tests_registered_methods():
    from startrack.matchers import available_methods

    names = set(available_methods())
    for claim in claims.CLAIMS:
        assert claim.original.rstrip().endswith(".") and len(claim.original) > 60
        assert all(t.a in names and t.b in names for t in claim.tests)
        assert all(t.measure in claims.MEASURES for t in claim.tests)
