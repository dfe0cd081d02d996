"""``--timeout-ms`` / ``timeout_ms``: one deadline per input across every stage of its
identification (the configured method, the FOV refit, the FOV search, the blind search).

No test here depends on how fast the machine is: the limits are 0 (or a microsecond, for
the CLI, which refuses 0), a deadline already passed, or a clock that the test moves.
"""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys

import numpy as np
import pytest
from waiting import CHILD_TIMEOUT_S

import startrack
import startrack.solver._deadline as deadline_module
from startrack.attitude import random_attitudes
from startrack.camera import Camera, stars_in_view
from startrack.centroids import Centroids
from startrack.errors import InputError
from startrack.outputs import frame_record
from startrack.sky import SkySpec, load_sky
from startrack.solver._deadline import Deadline
from startrack.solver._fov_refit import refit_fov
from startrack.solver._fov_search import BlindSolver, solve_approximate
from startrack.solver._identifier import Identifier
from startrack.solver._pipeline import FrameInput, Options, Pipeline

SKY = SkySpec(kind="random")
CAMERA = Camera.from_fov(1024, 1024, 20.0)
PASSED = Deadline(-1.0)  # long gone on any clock


def _centroids(seed: int = 3) -> np.ndarray:
    """x, y (brightest first) of one noisy frame of the random sky through ``CAMERA``."""
    catalog = load_sky(SKY)
    rng = np.random.default_rng(seed)
    for rot in random_attitudes(20, rng):
        _, x, y = stars_in_view(catalog, CAMERA, rot)
        if len(x) >= 12:
            return np.stack([x + rng.normal(0, 0.3, len(x)), y + rng.normal(0, 0.3, len(y))], 1)
    raise AssertionError("no frame with 12 stars")


def _frame(xy: np.ndarray) -> FrameInput:
    return FrameInput("sim", Centroids(xy[:, 0], xy[:, 1], np.arange(len(xy), 0, -1.0)))


def test_deadline_basics():
    assert not Deadline(None).passed() and PASSED.passed()
    assert Deadline.after_ms(0.0).passed()
    assert not Deadline.after_ms(60_000.0).passed()
    assert Deadline(5.0).earliest(Deadline(3.0)).at == 3.0
    assert Deadline(None).earliest(Deadline(3.0)).at == 3.0
    assert Deadline(5.0).earliest(None).at == 5.0


def test_no_fov_with_a_zero_timeout_is_a_timeout_through_the_api():
    xy = _centroids()
    result = startrack.solve(xy, size=(1024, 1024), sky="random", timeout_ms=0)
    assert not result.solved and result.reason == "timeout"
    record = result.to_dict()
    assert record["status"] == "not_solved" and record["reason"] == "timeout"


def test_no_fov_with_a_tiny_timeout_is_a_timeout_through_the_cli(tmp_path):
    xy = _centroids()
    path = tmp_path / "frame.csv"
    path.write_text("x,y\n" + "".join(f"{x:.4f},{y:.4f}\n" for x, y in xy))
    proc = subprocess.run([sys.executable, "-m", "startrack", "identify", str(path),
                           "--size", "1024x1024", "--sky", "random", "--format", "json",
                           "--timeout-ms", "1e-6"], capture_output=True, text=True,
                          timeout=CHILD_TIMEOUT_S)
    assert proc.returncode == 1, proc.stderr
    record = json.loads(proc.stdout)
    assert record["status"] == "not_solved" and record["reason"] == "timeout"


def test_a_negative_timeout_is_bad_input():
    with pytest.raises(InputError, match="timeout_ms"):
        Pipeline(Options(timeout_ms=-1.0))


def test_each_fov_stage_stops_at_a_passed_deadline():
    xy = _centroids()
    x, y = xy[:, 0], xy[:, 1]
    blind = BlindSolver(load_sky(SKY), SKY, 0.5, fov_range=(14.0, 34.0))
    assert blind.solve(x, y, (1024, 1024), PASSED).solution.reason == "timeout"
    quad = Identifier(CAMERA, load_sky(SKY), "quad")
    assert solve_approximate(quad, x, y, 0.1, PASSED).solution.reason == "timeout"
    # with time to spare the same searches answer, and the refit needs time too
    found = solve_approximate(quad, x, y, 0.1)
    assert found.solution.solved
    pipeline = Pipeline(Options(fov_deg=20.0, size=(1024, 1024), sky="random",
                                method="quad", fov_tolerance=0.0))
    first = pipeline.solve(_frame(xy))
    assert first.solution.solved
    ident = pipeline.identifier(first.camera, SKY)
    assert refit_fov(first, ident.database, ident.verify_config) is not None
    assert refit_fov(first, ident.database, ident.verify_config, PASSED) is None


def test_the_deadline_is_shared_by_the_fov_search_and_the_nominal_method(monkeypatch):
    """The FOV search uses up the limit (the test's clock jumps 2 s while it runs) and
    finds nothing: the configured method's first look after it must not start afresh, so
    the frame is a timeout; with no limit the same frame is solved by that search (its
    nominal FOV is 8 % off)."""
    from startrack.match_records import Solution
    from startrack.solver import _nominal

    xy = _centroids()
    options = dict(fov_deg=20.0 * 1.08, size=(1024, 1024), sky="random",
                   method="pyramid", fov_tolerance=0.1)  # not scale-free: tried after
    free = Pipeline(Options(**options)).solve(_frame(xy))
    assert free.solution.solved and free.camera.fov_deg == pytest.approx(20.0, abs=0.02)

    now = [100.0]
    monkeypatch.setattr(deadline_module, "clock", lambda: now[0])
    original, looked = _nominal.solve_approximate, []

    def slow_search(*args, **kwargs):
        found = original(*args, **kwargs)
        now[0] += 2.0
        return dataclasses.replace(found, solution=Solution(False, "quad", reason="no_match"))

    identify_as_ever = Identifier.identify

    def identify(self, obs, deadline=None, first_look=False):
        if first_look:
            looked.append(deadline.passed())
        return identify_as_ever(self, obs, deadline, first_look)

    monkeypatch.setattr(_nominal, "solve_approximate", slow_search)
    monkeypatch.setattr(Identifier, "identify", identify)
    limited = Pipeline(Options(**options, timeout_ms=1000.0)).solve(_frame(xy))
    assert looked and all(looked)  # the first look ran with the limit already spent
    assert not limited.solution.solved and limited.solution.reason == "timeout"
    assert frame_record(limited)["reason"] == "timeout"


def test_a_pair_table_over_budget_leaves_the_fov_search_to_answer(monkeypatch):
    """A deep sky for a narrow field (Gaia at 1.5 to 4 deg) has more catalog pairs than
    the budget: a nominal FOV is then searched by the quad matcher alone (no pair table),
    where an exact FOV (tolerance 0) with a pair-table method stays a one-line error."""
    monkeypatch.setenv("STARTRACK_MAX_PAIRS", "1000")
    xy = _centroids()
    options = dict(fov_deg=20.0 * 1.04, size=(1024, 1024), sky="random", method="pyramid")
    result = Pipeline(Options(**options, fov_tolerance=0.1)).solve(_frame(xy))
    assert result.solution.solved and result.solution.method == "quad"
    assert result.camera.fov_deg == pytest.approx(20.0, abs=0.02)
    with pytest.raises(InputError, match="pairs"):
        Pipeline(Options(**options, fov_tolerance=0.0)).solve(_frame(xy))


def test_an_unanswered_nominal_frame_counts_each_stage_once(monkeypatch):
    """Junk at a nominal FOV: the answer's time is the search's and the first look's,
    each once (the whole method's, last, left out here); it counted the search twice."""
    from startrack.solver import _nominal

    monkeypatch.setattr(_nominal, "_whole_method", lambda frame, nominal, deadline, failed:
                        failed)
    junk = _frame(np.random.default_rng(8).uniform(0, 1024, (40, 2)))
    pipeline = Pipeline(Options(fov_deg=20.0, size=(1024, 1024), sky="random",
                                method="pyramid", fov_tolerance=0.1))
    pipeline.solve(junk)  # every table loaded
    pipeline.trail.take()
    found = _nominal.approximate(pipeline, junk, pipeline.setup_for(junk)[0], SKY)
    steps = pipeline.trail.take()
    assert not found.solution.solved
    assert [s["stage"] for s in steps] == ["FOV search", "first look (brightest stars)"]
    assert found.solution.identify_ms == pytest.approx(sum(s["ms"] for s in steps), abs=0.01)
