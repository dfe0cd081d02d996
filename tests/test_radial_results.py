"""The radial-features section's paired tests and verdicts (scripts/_radial_paired.py,
scripts/_radial_claims.py): the same frames compared method against method."""

import sys
from pathlib import Path

import pandas as pd

sys.path.insert(0, str(Path(__file__).parents[1] / "scripts"))
import _radial_claims  # noqa: E402
import _radial_paired  # noqa: E402


def _frames(ok_a, ok_b, condition=0):
    rows = []
    for f, (a, b) in enumerate(zip(ok_a, ok_b, strict=True)):
        for method, ok in (("radial", a), ("sss", b)):
            rows.append({"condition": condition, "noise_px": 0.3 * (condition + 1),
                         "false_stars": condition, "frame": f, "method": method,
                         "correct": ok, "first_right": ok, "misidentified": int(not ok),
                         "duplicates": 0, "matcher_ms": 1.0 if method == "radial" else 2.0})
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


def test_the_verdict_names_the_conditions_where_only_they_hold():
    frames = pd.concat([_frames([True] * 12, [False] * 10 + [True] * 2, 0),
                        _frames([False] * 14, [True] * 14, 1)])
    text = _radial_claims.paired_verdict(_paired(frames), "verified correct", "radial", "sss")
    assert text.startswith("**reproduced only at** noise 0.3 px, 0 false")
    worse = _radial_claims.paired_verdict(_paired(_frames([False] * 12, [True] * 12)),
                                          "verified correct", "radial", "sss")
    assert worse.startswith("**not reproduced: the opposite holds**")
    assert _radial_claims.paired_verdict(_paired(_frames([True] * 3, [True] * 3)),
                                         "verified correct", "radial", "sss").startswith(
        "**not reproduced** (no difference shown")


def test_every_claim_is_quoted_in_full_with_a_translation():
    for claim in _radial_claims.CLAIMS:
        assert claim.original.endswith("。") and len(claim.english) > 40
        assert claim.kind in ("misid", "shortlist", "literal", "time", "tables", "duplicates")
