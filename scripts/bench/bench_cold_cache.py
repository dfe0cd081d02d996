"""Time identify with the CPU caches warm and flushed: what a solve pays to fetch its memory.

A bench that runs several solvers on each frame in turn (scripts/bench/bench_blind_peers.py)
times each one after the others have filled the caches, as a user's single `identify`
meets them too. This script solves scripts/bench/bench_blind.py's frames through the pipeline
(as bench_blind_peers.py's startrack does: loaded and warmed up before the clock) three
ways: each frame solved twice and the second solve timed ("same frame again"), the
frames in turn ("in turn"), and the frames in turn with a buffer larger than the
last-level cache written between them ("caches flushed"). The difference between the
last and the first is what the solve's code and data cost to fetch from memory. With
``--peers`` (installed: ``pip install -e '.[peers]'``) each peer is timed the same three
ways, told the same FOV error and tolerance as bench_blind_peers.py tells it.

    PYTHONPATH=. /work/peers-venv/bin/python scripts/bench/bench_cold_cache.py --peers tetra3rs
"""

from __future__ import annotations

import sys

import numpy as np

from scripts._cli import add_frames, script_parser  # noqa: E402
from scripts.bench.bench_blind import frames_for  # noqa: E402
from scripts.bench.bench_blind_peer_solvers import PEERS  # noqa: E402
from scripts.bench.bench_blind_peers import Ours, estimate, search_half_width  # noqa: E402

MODES = ("same frame again", "in turn", "caches flushed")


def parse_settings(text: str) -> list[tuple[str, float, float]]:
    """``method:fov error %:fov tolerance`` items, comma-separated."""
    out = []
    for item in text.split(","):
        method, err, tol = item.split(":")
        out.append((method, float(err), float(tol)))
    return out


def medians_us(solver, frames, fov: float, err: float, repeats: int,
               flush: np.ndarray) -> dict[str, float]:
    """Each mode's median identify time (µs, as ``solver.solve`` times itself) over
    ``repeats`` passes of ``frames``."""
    times: dict[str, list[float]] = {mode: [] for mode in MODES}
    for _ in range(repeats):
        for mode in MODES:
            for i, frame in enumerate(frames):
                est = estimate(fov, err, i)
                if mode == MODES[0]:
                    solver.solve(frame, est)
                elif mode == MODES[2]:
                    flush += 1.0  # every line of the buffer written: the caches hold it
                times[mode].append(solver.solve(frame, est)[1] * 1000.0)
    return {mode: float(np.median(v)) for mode, v in times.items()}


def main(argv: list[str] | None = None) -> int:
    ap = script_parser(__doc__)
    add_frames(ap, 40, seed=0)
    ap.add_argument("--fov", type=float, default=20.0, help="the frames' FOV (deg)")
    ap.add_argument("--settings", default="quad:2.5:0.025,pyramid:2.5:0.1,pyramid:0:0",
                    help="method:FOV error (%%):--fov-tolerance, comma-separated")
    ap.add_argument("--repeats", type=int, default=3, help="passes over the frames")
    ap.add_argument("--peers", default="", help="peers timed too, comma-separated: "
                    + ", ".join(PEERS))
    ap.add_argument("--flush-mb", type=float, default=64.0,
                    help="the buffer written between frames (larger than the cache)")
    args = ap.parse_args(argv)

    camera, frames, catalog = frames_for(args.fov, args.frames, args.seed, with_catalog=True)
    flush = np.zeros(int(args.flush_mb * 2**20) // 8)
    print(f"{len(frames)} frames, {args.fov:g} deg, seed {args.seed}; {args.repeats} passes; "
          f"{args.flush_mb:g} MB written between frames when flushed")
    print("| solver | FOV given | --fov-tolerance | "
          + " | ".join(f"{m} µs" for m in MODES) + " | flushed - same |")
    print("|---|---|---|" + "---|" * len(MODES) + "---|")
    for method, err, tol in parse_settings(args.settings):
        solvers = {method: Ours(camera, catalog.source["kind"], 10_000.0, tol, method)}
        for i in range(2):  # both estimates' pipelines loaded and warmed before the clock
            solvers[method].pipeline(estimate(args.fov, err, i))
        for name in filter(None, args.peers.split(",")):
            solvers[name] = PEERS[name](catalog, camera, args.fov, search_half_width(tol), tol,
                                        2.0, 10_000.0)
            solvers[name].solve(frames[0], estimate(args.fov, err, 0))  # loaded before
        for name, solver in solvers.items():
            med = medians_us(solver, frames, args.fov, err, args.repeats, flush)
            print(f"| {name} | {err:g}% off | {tol:g} | "
                  + " | ".join(f"{med[m]:.0f}" for m in MODES)
                  + f" | {med[MODES[2]] - med[MODES[0]]:.0f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
