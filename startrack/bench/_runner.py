"""Running a comparison: work units on local processes or a Dask cluster, with resume.

A work unit is one frame in one condition, run through every method. Units are
deterministic (frames.py), so where a unit runs changes only its timings. Finished units'
rows are appended to frames.csv and flushed; a rerun skips the units already there, and
the final files are rewritten in canonical order (a resumed run ends as an uninterrupted
one)."""

from __future__ import annotations

import contextlib
import ctypes
import os
import signal
import sys
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np

from startrack.bench._conditions import VARIABLES, Condition
from startrack.bench._frames import make_frame
from startrack.bench._metrics import FrameScore, score_frame
from startrack.camera import Camera
from startrack.errors import InputError
from startrack.simulate import Effects, SensorModel
from startrack.sky import SkySpec

KEY_COLUMNS = ["condition", *VARIABLES, "frame", "method"]
SCORE_COLUMNS = list(FrameScore.__dataclass_fields__)
# Per-frame attitudes (scalar-first, camera to ICRS): the truth and the answer (if any).
ATTITUDE_COLUMNS = [f"{who}_q{c}" for who in ("true", "solved") for c in "wxyz"]
COLUMNS = KEY_COLUMNS + SCORE_COLUMNS + ATTITUDE_COLUMNS
TIMING_COLUMNS = ("identify_ms", "method_ms", "centroid_ms")


@dataclass(frozen=True)
class RunSpec:
    """Everything that determines a comparison's numbers (not where or how fast it runs)."""

    methods: tuple[str, ...]
    conditions: tuple[Condition, ...]
    frames: int
    seed: int
    camera: Camera
    sky: SkySpec
    sensor: SensorModel = field(default_factory=SensorModel)
    source: str = "centroids"
    grid: str = "oat"
    max_stars: int = 5
    extra_stars: int | None = None  # None: the matchers' default (MatcherConfig)
    hot_pixel_fraction: float = 0.5
    threshold_arcsec: float = 60.0
    effects: Effects = field(default_factory=Effects)  # the config's; conditions set levels
    false_mags: str = "uniform"  # startrack.bench._frames.FALSE_MAGS

    def to_json(self) -> dict:
        """The run's identity, as stored in run.json and compared on resume (the effects
        only when a config turns one on: a run without them keeps its identity)."""
        effects = ({"effects": self.effects.to_dict()}
                   if self.source == "images" and not self.effects.is_off else {})
        return {
            "methods": list(self.methods),
            "conditions": [c.to_dict() for c in self.conditions],
            "frames": self.frames, "seed": self.seed, "source": self.source,
            "grid": self.grid, "max_stars": self.max_stars, "extra_stars": self.extra_stars,
            "hot_pixel_fraction": self.hot_pixel_fraction,
            "threshold_arcsec": self.threshold_arcsec,
            # named only when not the default, so that older runs still resume
            **({"false_mags": self.false_mags} if self.false_mags != "uniform" else {}),
            "camera": {"width": self.camera.width, "height": self.camera.height,
                       "f_px": self.camera.f_px, "cx": self.camera.cx, "cy": self.camera.cy},
            "sky": self.sky.to_dict(),
            "sensor": self.sensor.to_dict() if self.source == "images" else None,
            **effects,
        }

    def units(self) -> list[tuple[int, int]]:
        """Every (condition index, frame) in canonical order."""
        return [(c, f) for c in range(len(self.conditions)) for f in range(self.frames)]


@dataclass
class LoadedBench:
    """A worker's loaded sky, database and prepared matchers (one per method)."""

    spec: RunSpec
    identifiers: dict
    load_seconds: dict[str, float]

    def identifier(self, method: str, camera: Camera):
        """The method's identifier for the camera a condition tells it (built on first use
        when a condition's camera differs from the run's; not in ``load_seconds``)."""
        base = self.identifiers[method]
        if camera == base.camera:
            return base
        key = (method, camera)
        with _LOCK:
            if key not in self.identifiers:
                from startrack.solver import Identifier

                self.identifiers[key] = Identifier(camera, base.catalog, method,
                                                   max_stars=self.spec.max_stars,
                                                   extra_stars=self.spec.extra_stars)
        return self.identifiers[key]


_LOADED: dict[str, LoadedBench] = {}
_LOCK = threading.Lock()


def load_bench(spec: RunSpec) -> LoadedBench:
    """Load (once per process) the catalog and every method's database and matcher, each
    warmed by a throwaway frame (:meth:`~startrack.solver._identifier.Identifier.warm_up`), and
    for images the extraction too: no timed frame pays a one-time cost."""
    import json

    from startrack.sky import load_sky
    from startrack.solver import Identifier

    key = json.dumps(spec.to_json(), sort_keys=True)
    with _LOCK:  # Dask workers run tasks in threads: load once per process
        if key not in _LOADED:
            t0 = time.perf_counter()
            catalog = load_sky(spec.sky, spec.camera)
            seconds = {"sky": time.perf_counter() - t0}
            identifiers = {}
            for name in spec.methods:
                ident = Identifier(spec.camera, catalog, name, max_stars=spec.max_stars,
                                   extra_stars=spec.extra_stars)
                identifiers[name] = ident
                seconds[name] = ident.load_seconds
            if spec.source == "images":  # the extraction's kernels, before it is timed
                run_frame(spec, catalog, spec.conditions[0], 0)
            _LOADED[key] = LoadedBench(spec, identifiers, seconds)
        return _LOADED[key]


def bench_frame(spec: RunSpec, condition_index: int, frame: int):
    """The loaded bench, the condition and frame ``frame`` of it, as every method sees it."""
    bench = load_bench(spec)
    condition = spec.conditions[condition_index]
    return bench, condition, run_frame(spec, bench.identifiers[spec.methods[0]].catalog,
                                       condition, frame)


def run_frame(spec: RunSpec, catalog, condition: Condition, frame: int):
    """Frame ``frame`` of ``condition`` as the run makes it (:func:`make_frame`)."""
    return make_frame(catalog, spec.camera, condition, spec.seed, frame, source=spec.source,
                      sensor=spec.sensor, hot_pixel_fraction=spec.hot_pixel_fraction,
                      effects=spec.effects, false_mags=spec.false_mags)


def point_patch(matcher, bf) -> None:
    """Tell a matcher in known-sky-patch mode (``patch_rad`` set) where the frame points:
    the true boresight. Others are left alone (lost in space)."""
    if getattr(matcher, "patch_rad", None) is not None:
        matcher.patch_center = bf.rotation.apply([0.0, 0.0, 1.0])


def run_unit(spec: RunSpec, condition_index: int, frame: int) -> list[dict]:
    """One frame in one condition through every method: a row dict per method."""
    bench, condition, bf = bench_frame(spec, condition_index, frame)
    rows = []
    for name in spec.methods:
        ident = bench.identifier(name, bf.obs.camera)
        if not ident.warmed_up:  # the bench never times a compiler or a lazy table's fill
            raise RuntimeError(f"{name}: not warmed up before its first timed frame")
        point_patch(ident.matcher, bf)
        solution = ident.identify(bf.obs)
        rows.append(frame_row(condition_index, condition, frame, name, solution, bf,
                              spec.threshold_arcsec))
    return rows


def frame_row(condition_index: int, condition: Condition, frame: int, method: str,
              solution, bf, threshold_arcsec: float) -> dict:
    """One method's answer on one frame (a :class:`BenchFrame`), scored: a frames.csv row
    (:data:`COLUMNS`)."""
    from startrack.attitude import to_quaternion

    score = score_frame(solution, bf.truth_rows, bf.rotation, bf.n_in_view,
                        centroid_ms=bf.centroid_ms, threshold_arcsec=threshold_arcsec,
                        sigma_arcsec=float(np.degrees(bf.obs.sigma_rad)) * 3600.0)
    true_q = to_quaternion(bf.rotation)
    q = (to_quaternion(solution.rotation) if solution.solved
         and solution.rotation is not None else np.full(4, np.nan))
    return {"condition": condition_index, **condition.to_dict(), "frame": frame,
            "method": method, **score.to_dict(),
            **dict(zip(ATTITUDE_COLUMNS, map(float, [*true_q, *q]), strict=True))}


def run_chunk(spec: RunSpec, units: list[tuple[int, int]]) -> list[tuple[tuple, list[dict]]]:
    """Several units in a row (one task for a pool or a cluster: fewer round trips)."""
    return [((c, f), run_unit(spec, c, f)) for c, f in units]


def _die_with_parent(parent_pid: int) -> None:
    """Make this worker end when the process that started it does, even by SIGKILL
    (which runs no clean-up): the kernel's parent-death signal on Linux, and a thread
    watching for re-parenting everywhere."""
    if sys.platform.startswith("linux"):  # PR_SET_PDEATHSIG = 1; else the thread watches
        with contextlib.suppress(OSError, AttributeError):
            ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGKILL), 0, 0, 0)

    def watch() -> None:
        while os.getppid() == parent_pid:
            time.sleep(0.5)
        os._exit(1)

    if os.getppid() != parent_pid:  # the parent died before the signal was armed
        os._exit(1)
    threading.Thread(target=watch, daemon=True, name="parent-watch").start()


def _init_worker(spec: RunSpec, parent_pid: int) -> None:
    # The parent handles SIGTERM (and stops the pool); a worker just ends on it.
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    _die_with_parent(parent_pid)
    load_bench(spec)


def _chunks(units: list, workers: int) -> list[list]:
    size = max(1, min(8, len(units) // max(1, 4 * workers)))
    return [units[i:i + size] for i in range(0, len(units), size)]


def execute(spec: RunSpec, units: list[tuple[int, int]], *, jobs: int = 1,
            client=None) -> Iterator[tuple[tuple, list[dict]]]:
    """Yield (unit, rows) as units finish, in whatever order they finish: on the Dask
    ``client`` if given, else on ``jobs`` local processes."""
    if client is not None:
        yield from _execute_dask(spec, units, client)
    elif jobs <= 1:
        for c, f in units:
            yield (c, f), run_unit(spec, c, f)
    else:
        yield from _execute_local(spec, units, jobs)


def _execute_local(spec: RunSpec, units: list, jobs: int) -> Iterator:
    import os
    from concurrent.futures import ProcessPoolExecutor, as_completed

    pool = ProcessPoolExecutor(max_workers=jobs, initializer=_init_worker,
                               initargs=(spec, os.getpid()))
    finished = False
    try:
        futures = [pool.submit(run_chunk, spec, chunk) for chunk in _chunks(units, jobs)]
        for fut in as_completed(futures):
            yield from fut.result()
        finished = True
    finally:
        if not finished:  # stopped early (SIGTERM, an error): end the workers at once
            for process in list(getattr(pool, "_processes", {}).values()):
                process.terminate()
        pool.shutdown(wait=True, cancel_futures=True)


def connect(address: str):
    """A Dask client for the scheduler at ``address`` (InputError if it cannot be had)."""
    try:
        from distributed import Client
    except ImportError:
        raise InputError("--scheduler needs dask.distributed: pip install "
                         "'startrack[dask]'") from None
    try:
        return Client(address, timeout="20s")
    except (OSError, TimeoutError, ValueError) as exc:
        raise InputError(f"--scheduler: cannot connect to {address} ({exc})") from None


def _execute_dask(spec: RunSpec, units: list, client) -> Iterator:
    from distributed import as_completed

    n_workers = max(1, len(client.scheduler_info().get("workers", {})))
    futures = [client.submit(run_chunk, spec, chunk, pure=False)
               for chunk in _chunks(units, n_workers)]
    try:
        for fut in as_completed(futures):
            yield from fut.result()
    finally:
        client.cancel(futures)


def progress_bar(total: int, initial: int, enabled: bool):
    """The run's progress on stderr (:func:`startrack.outputs._progress.progress`: a bar on a
    terminal, a line every few seconds otherwise); silent unless ``enabled``."""
    from startrack.outputs import progress

    return progress(total, initial=initial, desc="compare", unit="frame", quiet=not enabled)

__all__ = [
    "ATTITUDE_COLUMNS", "COLUMNS", "KEY_COLUMNS", "LoadedBench", "RunSpec", "SCORE_COLUMNS",
    "TIMING_COLUMNS", "bench_frame", "connect", "execute", "frame_row", "load_bench",
    "point_patch", "progress_bar", "run_chunk", "run_unit",
]
