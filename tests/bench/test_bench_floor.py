"""scripts/bench/bench_floor.py and its clock (scripts/profile/_kernel_clock.py): the time
inside compiled kernels is counted where Python calls them, never more than the solve it is
part of, on bench_paths.py's paths, and every wrapped name is put back."""

import types

import pytest

from scripts.bench.bench_floor import floor_paths, floor_rows, line, tracking_table
from scripts.bench.bench_paths import Solvers
from scripts.profile._kernel_clock import KernelClock
from startrack.defaults import DEFAULT_FOV_TOLERANCE


def test_the_paths_are_bench_paths_exact_default_tolerance_and_ranged_rows():
    rows = floor_paths()
    assert rows[0] == ("FOV exact", "fov", 0.0, 0.0)
    assert [r[3] for r in rows if r[1] == "fov" and r[2] == DEFAULT_FOV_TOLERANCE] == [
        0.0, 2.5, 4.0]
    assert [r[1] for r in rows].count("range") == 1 and len(rows) == 5


def test_a_timed_call_returns_its_result_and_counts_only_while_counting():
    clock = KernelClock()
    timed = clock.timed(lambda a, b=1: a + b, "add")
    assert timed(2, b=3) == 5 and clock.take() > 0.0 and clock.take() == 0.0
    assert clock.by_kernel["add"] == [0.0, 0]  # not counting: time taken, nothing held
    clock.counting = True
    timed(1)
    timed(1)
    assert clock.by_kernel["add"][1] == 2
    text = clock.breakdown(2)
    assert text.startswith("1 timed calls a solve") and "add" in text and "(1.0 calls)" in text
    assert clock.by_kernel["add"] == [0.0, 0]


def test_a_raising_kernel_is_timed_and_raises():
    clock = KernelClock()

    def fails():
        raise ValueError("no")

    with pytest.raises(ValueError):
        clock.timed(fails)()
    assert clock.take() > 0.0


def test_every_solve_is_split_into_its_kernels_and_the_rest():
    args = types.SimpleNamespace(frames=3, seed=7, timeout_ms=5000.0, method="pyramid",
                                 span=1.7, peers=[])
    solvers = Solvers(20.0, args)
    for tolerance in (0.0, DEFAULT_FOV_TOLERANCE):
        solvers.ours(tolerance).pipeline(20.0)
    from startrack.solver import _fov_fit, _fov_search
    from startrack.verify._frame import FrameVerifier

    before = (FrameVerifier.check, _fov_fit.rounds_for, _fov_search.rounds_for)
    clock = KernelClock()
    clock.install()
    try:
        assert FrameVerifier.check is not before[0] and _fov_search.rounds_for is not before[2]
        rows = floor_rows(solvers, 20.0, args, clock)
    finally:
        clock.uninstall()
    # nothing else in the process is timed afterwards
    assert (FrameVerifier.check, _fov_fit.rounds_for, _fov_search.rounds_for) == before
    assert len(rows) == len(floor_paths())
    for row in rows:
        assert row["wrong"] == 0
        # the verification and the pattern search at least, never the whole solve
        assert 0.0 < row["kernels_ms"] < row["total_ms"], row
        assert row["rest_ms"] > 0.0  # the Python between the kernels
        assert line(row).count("|") == 12 and line(row).endswith("| - | - | - |")
        assert "Verifier.check" in row["kernels"] or "FittedRounds.run" in row["kernels"]


def test_the_tracking_table_gives_tracked_over_lost_in_space_with_and_without_python():
    rows = [{"path": "tracked frames", "frames": 199, "total_ms": 0.03, "kernels_ms": 0.02},
            {"path": "lost in space", "frames": 200, "total_ms": 0.12, "kernels_ms": 0.05}]
    text = tracking_table(rows)
    assert "| tracked frames | 199 | 0.0300 | 0.0200 |" in text
    assert text.splitlines()[-1] == "| tracked / lost in space | | 0.25 | 0.40 |"
