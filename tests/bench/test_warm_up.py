"""One-time costs are never timed: identify reports them as ``timing_ms.setup``, outside
``total``, and the bench warms every method in every worker before its first timed frame.

These tests check the mechanism (who warms what, and where a one-time cost is reported),
not how long anything takes."""

from __future__ import annotations

import json
import os
import types

import numpy as np
import pytest
from synth import synthetic_frame

from startrack.attitude import random_attitudes
from startrack.bench import _runner as runner
from startrack.bench._conditions import Condition
from startrack.bench._runner import RunSpec, execute
from startrack.camera import Camera
from startrack.outputs import frame_record
from startrack.sky import SkySpec, random_sky, resolve_sky
from startrack.solver import Identifier, Options, Pipeline
from startrack.solver import _identifier as identifier_module
from startrack.solver import _inputs as frame_input

CAMERA = Camera.from_fov(1024, 1024, 17.5)
METHODS = ("angle", "pyramid")


@pytest.fixture(scope="module")
def csv_frames(tmp_path_factory) -> list:
    """Two noisy frames of the random 2000-star sky (what --sky random loads) as CSVs."""
    tmp = tmp_path_factory.mktemp("warm")
    catalog, rng, paths = random_sky(2000, seed=0), np.random.default_rng(21), []
    for rotation in random_attitudes(8, rng):
        frame = synthetic_frame(catalog, CAMERA, rotation, rng, noise_px=0.2)
        if len(frame.obs) >= 10 and len(paths) < 2:
            paths.append(tmp / f"frame{len(paths)}.csv")
            paths[-1].write_text("x,y\n" + "".join(
                f"{x:.6f},{y:.6f}\n" for x, y in zip(frame.obs.x, frame.obs.y, strict=True)))
    return paths


def test_first_identify_reports_its_setup_outside_total(csv_frames, monkeypatch):
    # A clock that jumps an hour at every read inside the identifier module: every load
    # and warm-up there "takes" hours, the per-input stages (timed elsewhere) do not.
    ticks = iter(range(0, 10**9, 3600))
    monkeypatch.setattr(identifier_module, "time",
                        types.SimpleNamespace(perf_counter=lambda: float(next(ticks))))
    pipeline = Pipeline(Options(camera=CAMERA, sky="random", fov_tolerance=0.0))
    first, second = (frame_record(pipeline.run(p)) for p in csv_frames)
    assert first["status"] == second["status"] == "solved"
    t1, t2 = first["timing_ms"], second["timing_ms"]
    assert t1["setup"] >= 3600e3  # the identifier's load and warm-up, on the first input
    assert t2["setup"] == 0.0  # loaded once: the second input waited for nothing
    for t in (t1, t2):  # the per-input parts hold none of it
        assert t["total"] < 3600e3 and t["identify"] < 3600e3
        assert t["total"] >= t["centroid"] + t["identify"] - 1e-3
    assert json.loads(json.dumps(first))["timing_ms"]["setup"] == t1["setup"]


def test_the_first_extraction_of_a_pixel_type_is_warmed_outside_centroid_time(monkeypatch):
    monkeypatch.setattr(frame_input, "_warmed", set())  # as in a new process
    calls = []
    real = frame_input.warm_extraction
    monkeypatch.setattr(frame_input, "warm_extraction",
                        lambda image, config=None: calls.append(image.dtype) or real(image,
                                                                                     config))
    rng = np.random.default_rng(3)
    image = rng.poisson(100.0, (600, 700)).astype(np.uint16)
    image[300:303, 350:353] += 5000  # one star
    first = frame_input.image_input(image, "a")
    second = frame_input.image_input(image, "b")
    other = frame_input.image_input(image.astype(np.float32), "c")
    assert first.setup_ms > 0.0 and second.setup_ms == 0.0  # once per pixel type
    assert other.setup_ms > 0.0
    assert len(first.centroids) == len(second.centroids) == 1
    assert calls == [np.uint16, np.uint16, np.float32]


def test_identifier_warm_up_solves_one_throwaway_frame(monkeypatch):
    calls = []
    real = identifier_module.identify

    def spy(obs, matcher, *args, **kwargs):
        calls.append(len(obs))
        return real(obs, matcher, *args, **kwargs)

    monkeypatch.setattr(identifier_module, "identify", spy)
    ident = Identifier(CAMERA, random_sky(2000, seed=0), "pyramid")
    assert ident.warmed_up
    assert len(calls) == 1 and calls[0] >= 4  # a frame with stars to match, not an empty one


def test_the_runner_refuses_to_time_a_cold_method(monkeypatch):
    spec = _spec(seed=11)
    bench = runner.load_bench(spec)
    assert all(ident.warmed_up for ident in bench.identifiers.values())
    monkeypatch.setattr(bench.identifiers["pyramid"], "warmed_up", False)
    with pytest.raises(RuntimeError, match="not warmed up"):
        runner.run_unit(spec, 0, 0)


def test_every_worker_warms_every_method_before_its_first_timed_frame(tmp_path,
                                                                      monkeypatch):
    """With two worker processes (forked: they inherit the spies), each records its
    warm-ups and timed identifies in a log; every timed identify must follow its
    method's warm-up in the same process."""
    log = tmp_path / "log"
    warm_up, identify = Identifier.warm_up, Identifier.identify

    def note(*words) -> None:
        with open(log, "a") as fh:
            fh.write(" ".join(map(str, (os.getpid(), *words))) + "\n")

    def spy_warm_up(self):
        warm_up(self)
        note("warm", self.matcher.name)

    def spy_identify(self, obs, deadline=None):
        note("timed", self.matcher.name)
        return identify(self, obs, deadline)

    monkeypatch.setattr(Identifier, "warm_up", spy_warm_up)
    monkeypatch.setattr(Identifier, "identify", spy_identify)
    spec = _spec(seed=12)
    done = list(execute(spec, spec.units(), jobs=2))
    assert len(done) == len(spec.units())
    events = [line.split() for line in log.read_text().splitlines()]
    timed = [e for e in events if e[1] == "timed"]
    assert {e[2] for e in timed} == set(METHODS)
    for pid, _, method in timed:
        first_timed = events.index([pid, "timed", method])
        assert events.index([pid, "warm", method]) < first_timed
    warms = [(e[0], e[2]) for e in events if e[1] == "warm"]
    assert len(warms) == len(set(warms))  # once per method and process


def _spec(seed: int) -> RunSpec:
    return RunSpec(methods=METHODS, conditions=(Condition(noise_px=0.3),), frames=4,
                   seed=seed, camera=CAMERA, sky=resolve_sky(SkySpec(), CAMERA))
