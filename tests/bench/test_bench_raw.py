"""Raw scoring helpers: unchecked pairs, matcher-only time, five-star scores; and the
results doc's table and run-record helpers (scripts/papers/_results_doc.py)."""

import time

import numpy as np
import pandas as pd
import pytest

from scripts.papers import _results_doc  # noqa: E402
from startrack.bench._raw import TimedMatcher, _top_ids_right, pairs_off
from startrack.match_records import Hypothesis, MatchDiagnostics, Solution


def _unit(v):
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v, axis=1, keepdims=True)


STARS = _unit([[0, 0, 1], [0.05, 0, 1], [0, 0.05, 1], [0.04, 0.04, 1]])


def test_pairs_off_counts_only_the_pairs_that_disagree():
    assert pairs_off(STARS, STARS, 1e-6) == 0
    moved = STARS.copy()
    moved[3] = _unit([[0.04, 0.07, 1]])[0]
    # star 3 moved: its three pairs disagree, the other three agree
    assert pairs_off(STARS, moved, 1e-4) == 3
    assert pairs_off(STARS, moved, 1.0) == 0


CLOCK = [0.0]


class _Slow:
    name = "slow"
    database = "db"

    def hypotheses(self, obs, diag, screen_rad=None):
        for k in range(3):
            CLOCK[0] += 0.010  # 10 ms of matching per hypothesis
            diag.pivots += 1
            yield Hypothesis(np.array([k]), np.array([k]))


def test_timed_matcher_counts_time_inside_the_generator_only(monkeypatch):
    monkeypatch.setattr(time, "perf_counter", lambda: CLOCK[0])
    timed = TimedMatcher(_Slow())
    assert timed.name == "slow" and timed.database == "db"
    diag = MatchDiagnostics()
    for _ in timed.hypotheses(None, diag):
        CLOCK[0] += 0.020  # the consumer's work (verification) is not the matcher's
    assert diag.pivots == 3
    assert timed.ms == pytest.approx(30.0)


def test_five_star_score_looks_at_the_five_brightest_only():
    truth = np.array([10, 11, 12, 13, 14, 15, -1])
    right = Solution(True, "m", obs_index=np.array([0, 1, 2, 6]),
                     cat_index=np.array([10, 11, 12, 99]))
    assert _top_ids_right(right, truth)  # the wrong identity is spot 6, not in the five
    wrong = Solution(True, "m", obs_index=np.array([0, 1, 2]), cat_index=np.array([10, 11, 13]))
    assert not _top_ids_right(wrong, truth)
    two = Solution(True, "m", obs_index=np.array([0, 1, 5]), cat_index=np.array([10, 11, 15]))
    assert not _top_ids_right(two, truth)  # only two of the five identified
    assert not _top_ids_right(Solution(False, "m"), truth)


def test_fmt_table_formats_and_marks_missing_columns():
    t = pd.DataFrame({"a": [0.5, np.nan], "b": ["x", "y"]})
    text = _results_doc.fmt_table(t, [("A", "a", "{:.0%}"), ("B", "b", None), ("C", "c", "{}")])
    lines = text.splitlines()
    assert lines[0].split() == ["A", "B", "C"]
    assert lines[1].split() == ["50%", "x", "-"] and lines[2].split() == ["-", "y", "-"]


def test_run_record_names_commit_command_and_load(tmp_path):
    record = _results_doc.run_record(["--frames", "3"], "scripts/x.py")
    assert record["command"] == ".venv/bin/python scripts/x.py --frames 3"
    assert len(record["load_start"]) == 3 and record["git commit"]
    _results_doc.save_run(tmp_path, record, wall_s=1.5)
    back = _results_doc.load_run(tmp_path)
    assert back["wall_s"] == 1.5 and "finished" in back
    block = _results_doc.run_block(back, "x")
    assert "scripts/x.py --frames 3" in block and "Python" in block
    assert "not run yet" in _results_doc.run_block(None, "x")
