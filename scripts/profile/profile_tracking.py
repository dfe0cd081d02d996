"""Where a tracked frame's time goes, against lost-in-space's on the same frames.

The sequence is bench_tracking.py's first one (200 frames at 10 fps, (1, 0.5, 2) deg/s,
0.5 px, 2 false stars, 10% missing; configs/hipparcos20.toml). Prints, as medians over
the frames:

1. In the flow (each frame once, as ``identify --track`` runs it): the tracked frame's
   identify time, split into the compiled attempts and the Python around them (prediction
   included); lost-in-space's (pyramid) identify time, split into its pattern search
   and its verification.
2. The prediction's test alone, over the captured frames in turn (so no frame's
   branches are learnt by repeating it): the whole compiled call, its match at the
   prediction and bound (one call each to verification's compiled entry points), and the
   rest of the call, verification's refinement and labelling, by difference; the whole
   test again, each called right after lost-in-space has identified its frame, as a
   tracked frame finds the caches in the flow.
3. What bounds the ratio: a tracked frame is refined and labelled as lost-in-space's
   accepted hypothesis is, so lost-in-space / tracking is at most lost-in-space over
   those kernels alone.

    .venv/bin/python scripts/profile/profile_tracking.py [--frames 200] [--seed 0]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from startrack._core.tracking import tracked_frame as ct
from startrack._core.verify import entry_points as cv
from startrack.bench import _tracking_bench as tb
from startrack.simulate import load_config
from startrack.sky import load_sky, resolve_sky
from startrack.solver import Identifier
from startrack.tracking import Tracker
from startrack.tracking import _tracked_solve as tracking

ROOT = Path(__file__).resolve().parents[2]
WHOLE_KEY = "prediction's test (whole)"
MATCH_KEY = "match at the prediction + bound"
SHARED_KEY = "refine + label (verification's; the whole less the match and bound)"
FLOW_KEY = "prediction's test (whole), right after lost-in-space identified the frame"


class _Clock:
    """Seconds spent inside wrapped callables, per frame."""

    def __init__(self) -> None:
        self.spent = 0.0

    def wrap(self, fn):
        def timed(*args, **kwargs):
            t0 = time.perf_counter()
            try:
                return fn(*args, **kwargs)
            finally:
                self.spent += time.perf_counter() - t0
        return timed

    def wrap_iter(self, fn):
        def timed(*args, **kwargs):
            it = iter(fn(*args, **kwargs))
            while True:
                t0 = time.perf_counter()
                try:
                    item = next(it)
                except StopIteration:
                    self.spent += time.perf_counter() - t0
                    return
                self.spent += time.perf_counter() - t0
                yield item
        return timed


def _in_flow(seq, ident):
    """Per frame: tracked identify ms, attempts' ms, LIS identify ms, LIS search ms; and
    the prediction test's arguments of the frames it solved."""
    tracker, captured = Tracker(), []
    kernel, search = _Clock(), _Clock()
    attempts = {name: getattr(tracking, name) for name in ("attempt_at_prior", "attempt")}

    def capture(*args):  # ``frame``: the loop's frame being stepped when this is called
        out = attempts["attempt_at_prior"](*args)
        if out.status == ct.ACCEPTED:
            captured.append((args, frame.obs))
        return out
    tracking.attempt_at_prior = kernel.wrap(capture)
    tracking.attempt = kernel.wrap(attempts["attempt"])
    matcher = ident.matcher
    hypotheses = matcher.hypotheses
    matcher.hypotheses = search.wrap_iter(hypotheses)
    rows = []
    try:
        for frame in seq:
            kernel.spent = search.spent = 0.0
            tracked = tracker.step(frame.obs, ident.database, ident.verify_config,
                                   ident.identify, "pyramid")
            attempt_ms = kernel.spent * 1e3
            search.spent = 0.0
            lis = ident.identify(frame.obs)
            if tracked.mode == "tracking" and lis.solved:
                rows.append((tracked.identify_ms, attempt_ms, lis.identify_ms,
                             search.spent * 1e3))
    finally:
        for name, fn in attempts.items():
            setattr(tracking, name, fn)
        matcher.hypotheses = hypotheses
    return np.array(rows), captured


def _stages(captured, ident, repeats=5):
    """Median microseconds of the prediction's test, whole and its match and bound, the
    captured frames taken in turn; then the whole test again, each right after
    lost-in-space (``ident``) has identified the frame."""
    prepared = []
    for args, _ in captured:
        held, frame, prior, sigma, setup = args
        window = setup.window_px(sigma)
        match = (frame, held.vectors, prior, window)
        obs_m, _, n_in = cv.match(*match)
        bound = (len(obs_m), frame.n, n_in, window, setup.area)
        prepared.append((args, match, bound))
    calls = {WHOLE_KEY: lambda p: ct.attempt_at_prior(*p[0]),
             MATCH_KEY: lambda p: (cv.match(*p[1]), ct.prior_bound(*p[2]))}
    out = {}
    for name, call in calls.items():
        times = []
        for _ in range(repeats):
            for p in prepared:
                t0 = time.perf_counter()
                call(p)
                times.append(time.perf_counter() - t0)
        out[name] = float(np.median(times)) * 1e6
    out[SHARED_KEY] = out[WHOLE_KEY] - out[MATCH_KEY]
    times = []
    for _ in range(repeats):
        for (_, obs), p in zip(captured, prepared, strict=True):
            ident.identify(obs)
            t0 = time.perf_counter()
            ct.attempt_at_prior(*p[0])
            times.append(time.perf_counter() - t0)
    out[FLOW_KEY] = float(np.median(times)) * 1e6
    return out


def report(catalog, camera, frames: int = 200, seed: int = 0) -> str:
    """The three sections as markdown lines (what :func:`main` prints), on
    configs/hipparcos20.toml's catalog and camera."""
    ident = Identifier(camera, catalog, "pyramid")
    seq = tb.make_sequence(catalog, camera, tb.TrackCondition(), frames, 10.0, seed)
    _in_flow(seq[:20], ident)  # compile and warm
    rows, captured = _in_flow(seq, ident)
    tracked, kernel, lis, search = np.median(rows, axis=0) * 1e3
    stages = _stages(captured, ident)
    shared, cold = stages[SHARED_KEY], stages[FLOW_KEY]
    whole = stages[WHOLE_KEY]
    lines = [f"{len(rows)} frames tracked and solved by lost-in-space; medians in "
             "microseconds.", "",
             "In the flow (each frame once, as `identify --track` runs it):", "",
             f"- tracked frame: {tracked:.1f} (the compiled attempts {kernel:.1f}, the Python "
             f"around them {tracked - kernel:.1f}, prediction included)",
             f"- lost-in-space: {lis:.1f} (its pattern search {search:.1f}, verification "
             f"and the rest {lis - search:.1f})",
             f"- lost-in-space / tracked: {lis / tracked:.2f}x", "",
             "The prediction's test, stage by stage, the frames taken in turn:", ""]
    lines += [f"- {name}: {us:.1f}" for name, us in stages.items()]
    lines += ["", "What bounds the ratio (a tracked frame is refined and labelled as "
              "lost-in-space's accepted hypothesis is, so tracking saves the pattern search "
              "and the hypotheses' first tests, not the labelling):", "",
              f"- lost-in-space less its search alone would be {lis / (lis - search):.1f}x",
              f"- a tracked frame costing nothing but its compiled test ({whole:.1f}, timed "
              f"alone: no Python) would be {lis / whole:.1f}x",
              f"- a tracked frame costing nothing but verification's refinement and "
              f"labelling ({shared:.1f}, no matching, no Python) would be "
              f"{lis / shared:.1f}x",
              f"- the compiled test with the caches as the flow leaves them ({cold:.1f}) "
              f"would be {lis / cold:.1f}x"]
    return "\n".join(lines)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=200)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    cfg = load_config(ROOT / "configs" / "hipparcos20.toml")
    catalog = load_sky(resolve_sky(cfg.sky, cfg.camera), cfg.camera)
    print(report(catalog, cfg.camera, args.frames, args.seed))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
