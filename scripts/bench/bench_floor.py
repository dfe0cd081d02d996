"""The compiled floor of a solve: how much of startrack's time on a lost-in-space path is
spent inside its compiled kernels, and that floor beside tetra3rs's whole solve of the same
frames in the same run.

bench_paths.py's frames and paths (FOV exact; the FOV 0, 2.5 and 4% off at the CLI's
default tolerance; blind with the peers' range), each row solved as a batch (each solver a
row's frames back to back, once untimed to warm, then timed). Inside startrack's timed
solve (``Pipeline.solve``, as bench_paths.py times it) every call into a compiled kernel
is timed where Python makes it (scripts/profile/_kernel_clock.py): the functions of
``startrack._core`` modules as the Python stages call them (the pattern searches, the
camera fits, the evidence refit and its catalog scan, the cone lookups), the frame's
verification (``FrameVerifier.check``) and the fitted rounds (``FittedRounds.run`` and
``pattern_focal``). What is left is the Python and numpy between them (and a few compiled
calls made through other compiled objects, counted with it: an upper bound on the
Python's share).

* ``kernels ms``: the median over the frames of the time inside compiled kernels;
* ``rest ms``: the median of the rest of each solve (its Python and numpy);
* ``floor / tetra3rs``: the kernels' median over tetra3rs's median: what startrack's
  solve would cost beside tetra3rs with no Python at all between its kernels.

The tracking table: bench_tracking.py's sequence through startrack's tracker and its lost
in space alone, each frame's reported time (bench_paths.py's tracking rows) and the
kernels of the whole call; its last row, tracked over lost in space, with and without the
Python. Each timer costs about 0.25 us, counted in the kernels. Run with the peers' venv
(without tetra3rs only startrack's columns are filled), on a quiet machine:

    PYTHONPATH=. /work/peers-venv/bin/python scripts/bench/bench_floor.py [--frames 20] \
        [--track-frames 200] [--doc docs/speed.md]

With ``--doc`` the table, with the command, commit, date and load average, replaces what is
between the doc's ``<!-- bench_floor:start -->`` and ``<!-- bench_floor:end -->`` markers.
"""

from __future__ import annotations

import datetime as dt
import os
import sys
import time
from pathlib import Path

import numpy as np

from scripts._cli import add_frames, script_parser  # noqa: E402
from scripts.bench.bench_blind import floats, provenance_line, write_between  # noqa: E402
from scripts.bench.bench_paths import (  # noqa: E402
    Solvers,
    add_solver_options,
    paths,
    score,
    solve_order,
    told,
)
from scripts.bench.bench_tracking import base_runners  # noqa: E402
from scripts.profile._kernel_clock import KernelClock  # noqa: E402
from startrack.defaults import DEFAULT_FOV_TOLERANCE  # noqa: E402

#: the range's span of the ranged row (bench_paths.py's default)
SPAN = 1.7


def floor_paths() -> list[tuple[str, str, float, float | None]]:
    """(path, kind, startrack's tolerance, FOV error in %) of the rows measured:
    bench_paths.py's FOV exact, its rows at the default tolerance and its ranged row."""
    return [row for row in paths(SPAN) if row[1] == "range"
            or (row[1] == "fov" and row[2] in (0.0, DEFAULT_FOV_TOLERANCE))]


def floor_rows(solvers: Solvers, fov: float, args, clock: KernelClock) -> list[dict]:
    """One row per path at FOV ``fov`` (``solvers``' frames)."""
    rows = []
    for turn, (label, kind, tolerance, err) in enumerate(floor_paths()):
        each = {"startrack": solvers.ours(tolerance)}
        if "tetra3rs" in args.peers:
            each["tetra3rs"] = solvers.peer("tetra3rs", tolerance)
        frames = solvers.frames
        for name, solver in each.items():  # warm: every table and path touched untimed
            for i in range(len(frames)):
                solver.solve(frames[i], told(fov, SPAN, kind, err, i)[name != "startrack"])
        times = {name: [] for name in each}
        kernels, wrong = [], 0
        for i, name in solve_order(len(frames), list(each), "batch", turn):
            est_ours, est_peer = told(fov, SPAN, kind, err, i)
            clock.take()
            clock.counting = name == "startrack"
            answer, ms = each[name].solve(frames[i], est_ours if name == "startrack" else est_peer)
            clock.counting = False
            inside = clock.take() * 1000.0
            times[name].append(ms)
            if name == "startrack":
                kernels.append(inside)
                wrong += score(answer, frames[i], solvers.catalog, solvers.camera)[1]
        ours = np.asarray(times["startrack"])
        row = {"fov": f"{fov:g}", "path": label, "frames": len(frames), "wrong": wrong,
               "total_ms": float(np.median(ours)), "kernels_ms": float(np.median(kernels)),
               "rest_ms": float(np.median(ours - np.asarray(kernels)))}
        if "tetra3rs" in times:
            row["tetra3rs_ms"] = float(np.median(times["tetra3rs"]))
        row["kernels"] = clock.breakdown(len(frames))
        rows.append(row)
        print(line(row), flush=True)
        print(f"    {row['kernels']}", flush=True)
    return rows


def line(row: dict) -> str:
    peer = row.get("tetra3rs_ms")
    cells = [row["fov"], row["path"], str(row["frames"]), str(row["wrong"]),
             f"{row['total_ms']:.3f}", f"{row['kernels_ms']:.3f}", f"{row['rest_ms']:.3f}",
             f"{row['kernels_ms'] / row['total_ms']:.0%}",
             "-" if peer is None else f"{peer:.3f}",
             "-" if peer is None else f"{row['total_ms'] / peer:.2f}x",
             "-" if peer is None else f"{row['kernels_ms'] / peer:.2f}x"]
    return "| " + " | ".join(cells) + " |"


def table(rows: list[dict]) -> str:
    head = ["| FOV (deg) | path | frames | startrack wrong | startrack median ms | "
            "kernels ms | rest ms | kernels' share | tetra3rs median ms | "
            "startrack / tetra3rs | floor / tetra3rs |", "|" + "---|" * 11]
    return "\n".join(head + [line(r) for r in rows])


def tracking_rows(args, clock: KernelClock) -> list[dict]:
    """bench_tracking.py's sequence (Hipparcos 20 deg, 10 fps) through startrack's tracker
    and its lost in space alone (pyramid), each through the whole sequence once untimed
    (a fresh tracker), then timed: each frame's reported time (its ``identify_ms``, as
    bench_paths.py reports it; the tracked frames only for the tracker) and the kernels
    inside the whole call (the tracker's prediction too)."""
    seq, runners = base_runners(args.track_frames, args.seed)
    rows = []
    for label, make in runners.items():
        warm = make()
        for frame in seq:
            warm(frame.obs)
        run, reported, kernels = make(), [], []
        for frame in seq:
            clock.take()
            clock.counting = True
            solution = run(frame.obs)
            clock.counting = False
            inside = clock.take() * 1000.0
            if label == "tracked frames" and solution.mode != "tracking":
                continue
            reported.append(solution.identify_ms)
            kernels.append(inside)
        rows.append({"path": label, "frames": len(reported),
                     "total_ms": float(np.median(reported)),
                     "kernels_ms": float(np.median(kernels)),
                     "kernels": clock.breakdown(max(len(reported), 1))})
        print(f"tracking, {label}: {rows[-1]}", flush=True)
    return rows


def tracking_table(rows: list[dict]) -> str:
    tracked, alone = rows
    lines = ["| sequence | frames | startrack median ms | kernels ms |",
             "|---|---|---|---|"]
    lines += [f"| {r['path']} | {r['frames']} | {r['total_ms']:.4f} | {r['kernels_ms']:.4f} |"
              for r in rows]
    lines.append(f"| tracked / lost in space | | {tracked['total_ms'] / alone['total_ms']:.2f} "
                 f"| {tracked['kernels_ms'] / alone['kernels_ms']:.2f} |")
    return "\n".join(lines)


def kernels_list(rows: list[dict]) -> str:
    """Each row's kernels, the most time first (means per solve), as a markdown list."""
    return "\n".join(f"* {r['fov'] + ' deg, ' if 'fov' in r else 'tracking, '}{r['path']}: "
                     f"{r['kernels']}" for r in rows)


def main() -> None:
    ap = script_parser(__doc__)
    add_frames(ap, 20, seed=7)
    add_solver_options(ap)
    ap.add_argument("--peers", default="tetra3rs",
                    help="'tetra3rs' for its column, '' for startrack alone")
    ap.add_argument("--track-frames", type=int, default=200,
                    help="frames of the tracking sequence (0: no tracking rows)")
    ap.add_argument("--doc", type=Path, help="write the table between this doc's markers")
    args = ap.parse_args()
    started = dt.datetime.now(dt.UTC).strftime("%Y-%m-%d %H:%M")
    load0, t0 = os.getloadavg()[0], time.perf_counter()
    args.peers = [name for name in args.peers.split(",") if name]
    if set(args.peers) - {"tetra3rs"}:
        ap.error("--peers: only tetra3rs (or none) is measured here")
    args.span = SPAN  # the peers' databases span the ranged row's range (Solvers.peer)
    clock, rows = KernelClock(), []
    for fov in floats(args.fovs):
        solvers = Solvers(fov, args)
        if not clock.installed:  # the stages load on a first solve: wrap once all are in
            for _, kind, tolerance, err in floor_paths():
                solvers.ours(tolerance).pipeline(told(fov, SPAN, kind, err, 0)[0])
            clock.install()
            print(table([]).split("\n")[0], flush=True)
        rows += floor_rows(solvers, fov, args, clock)
    tracking = tracking_rows(args, clock) if args.track_frames else []
    text = table(rows) + ("\n\n" + tracking_table(tracking) if tracking else "")
    print(text)
    if args.doc:
        head = provenance_line("bench_floor.py", started, (time.perf_counter() - t0) / 60.0,
                               (load0, os.getloadavg()[0]))
        write_between(args.doc, "<!-- bench_floor:start -->", "<!-- bench_floor:end -->",
                      f"{head} tetra3rs from the peers' venv; startrack --method "
                      f"{args.method}; frames solved in batch order.\n\n{text}\n\n"
                      "The kernels of each row (means per solve):\n\n"
                      f"{kernels_list(rows + tracking)}")


if __name__ == "__main__":
    sys.exit(main())
