"""Every solving path, startrack beside tetra3rs, cedar-solve and astrometry.net, in one
table: each row a path a user takes, with each solver's solved, wrong and median solve time
on the same frames and the ratio of startrack's median to each peer's, all from one run
(``--peers`` picks them; astrometry.net is ``solve-field`` on the centroid list, a process
a frame, as scripts/bench/bench_blind_peers.py runs it: told the same FOV range, none when
blind, its own time limit the same).

Paths (lost in space on bench_blind.py's frames, 0.3 px, 3 false stars, 5% missing):

* FOV exact: startrack ``--fov-tolerance 0``; the peers a half-width of
  bench_blind_peers.EXACT_HALF_WIDTH (tetra3rs solves nothing with none). The peers are
  given what tetra3rs is below: cedar-solve (its ``tetra3`` module, the Python tetra3) the
  same database range, FOV estimate and error.
* FOV 0 / 2.5 / 4% off (half the frames above, half below) at ``--fov-tolerance`` 0.025 and
  at the CLI's default: tetra3rs searches the same half-width (bench_blind_peers).
* Blind with a range: both given the same FOV range, ``[FOV / span, FOV x span]``
  (``--span``; startrack as ``--scale-low/--scale-high`` would give it, tetra3rs as the
  range's centre with the range as its error, on a database over that range).
* Blind with no range: startrack no FOV at all (its 0.8 to 40 deg search); tetra3rs the same
  as above (it has no unknown-FOV mode): more information than startrack gets.
* Junk: ``--frames`` sets of 40 random points, FOV given at the default tolerance; any
  answer is wrong.
* Tracking: scripts/bench/bench_tracking.py's sequence (200 frames at 10 fps, Hipparcos
  20 deg): startrack's tracker (pyramid) beside tetra3rs's ``attitude_hint`` mode, and each
  one's lost in space on the same frames.

Loading (databases, tables, a warm-up solve) is outside the timed span. ``--order batch``
(the default): each solver solves a row's frames back to back, as a batch of inputs or a
tracker in flight does, the solvers' turns rotating row by row; ``--order interleaved``:
each frame by every solver in turn, so that each solve starts with the caches the other
solvers left (a process doing other work between frames). Either way the machine's load
falls on all alike. Run with the peers' venv (``pip install -e '.[peers]'``), on a quiet
machine:

    PYTHONPATH=. /work/peers-venv/bin/python scripts/bench/bench_paths.py \
        [--frames 20] [--fovs 11.4,20,30] [--order batch] [--doc docs/speed.md]
"""

from __future__ import annotations

import datetime as dt
import os
import time
import types
from pathlib import Path

import numpy as np

from scripts._cli import add_frames, script_parser  # noqa: E402
from scripts.bench.bench_blind import (  # noqa: E402
    WRONG_ARCSEC,
    boresight_arcsec,
    floats,
    frames_for,
    provenance_line,
    write_between,
    wrong_stars,
)
from scripts.bench.bench_blind_peer_solvers import Astrometry, Tetra3, Tetra3rs  # noqa: E402
from scripts.bench.bench_blind_peers import (  # noqa: E402
    Ours,
    estimate,
    search_half_width,
)
from scripts.bench.bench_tracking import sequence_summary  # noqa: E402
from startrack.defaults import DEFAULT_FOV_TOLERANCE, DEFAULT_METHOD  # noqa: E402
from startrack.match_records import Observation  # noqa: E402

#: each peer: its solver class (scripts/bench/bench_blind_peer_solvers.py)
PEERS = {"tetra3rs": Tetra3rs, "cedar-solve": Tetra3, "astrometry.net": Astrometry}
#: the peers run unless ``--peers`` says otherwise: all of them (astrometry.net's
#: ``solve-field`` from ``make astrometry``)
DEFAULT_PEERS = tuple(PEERS)
#: how a row's frames are dealt out to the solvers (solve_order)
ORDERS = ("batch", "interleaved")


def paths(span: float) -> list[tuple[str, str, float, float | None]]:
    """(path, kind, startrack's tolerance, FOV error in %) for every lost-in-space row."""
    rows = [("FOV exact", "fov", 0.0, 0.0)]
    for tolerance in (0.025, DEFAULT_FOV_TOLERANCE):
        rows += [(f"FOV {err:g}% off, tolerance {tolerance:g}", "fov", tolerance, err)
                 for err in (0.0, 2.5, 4.0)]
    lo, hi = 1.0 / span, span
    rows += [(f"blind, range FOV/{span:g} to FOV x{span:g}", "range", (hi - lo) / (hi + lo), None),
             ("blind, no range", "blind", DEFAULT_FOV_TOLERANCE, None),
             ("junk (40 random points), FOV given", "junk", DEFAULT_FOV_TOLERANCE, 0.0)]
    return rows


def junk_frames(camera, n: int, seed: int) -> list:
    """``n`` frames of 40 random points (no truth: any answer is wrong)."""
    rng = np.random.default_rng(seed)
    frames = []
    for _ in range(n):
        x, y = rng.uniform(0, camera.width - 1, 40), rng.uniform(0, camera.height - 1, 40)
        frames.append(types.SimpleNamespace(obs=Observation.from_pixels(x, y, camera, 0.3)))
    return frames


class Solvers:
    """Every solver for one FOV, one instance per tolerance (loaded once, untimed)."""

    def __init__(self, fov: float, args) -> None:
        self.fov, self.args = fov, args
        self.camera, self.frames, self.catalog = frames_for(fov, args.frames, args.seed,
                                                            with_catalog=True)
        self._ours: dict[float, Ours] = {}
        self._peer: dict[tuple[str, float], object] = {}

    def ours(self, tolerance: float) -> Ours:
        if tolerance not in self._ours:
            self._ours[tolerance] = Ours(self.camera, self.catalog.source["kind"],
                                         self.args.timeout_ms, tolerance, self.args.method)
        return self._ours[tolerance]

    def peer(self, name: str, tolerance: float):
        if (name, tolerance) not in self._peer:
            self._peer[name, tolerance] = PEERS[name](
                self.catalog, self.camera, self.fov, search_half_width(tolerance), tolerance,
                self.args.span, self.args.timeout_ms)
        return self._peer[name, tolerance]


def told(fov: float, span: float, kind: str, err: float | None,
         i: int) -> tuple[float | None, float | None]:
    """What startrack and tetra3rs are told of frame ``i``'s FOV (true width ``fov``) on
    a row of ``kind``: the range's centre for startrack and none for tetra3rs (its
    database holds the range), nothing when blind, else the same estimate ``err``% off."""
    if kind == "range":
        return fov * (span + 1.0 / span) / 2.0, None
    if kind == "blind":
        return None, None
    est = estimate(fov, err, i)
    return est, est


def score(answer, frame, catalog, camera) -> tuple[bool, bool]:
    """(solved, wrong) of one answer; on junk every answer is wrong."""
    if answer is None:
        return False, False
    if not hasattr(frame, "rotation"):
        return True, True
    rotation, obs_index, cat_vectors = answer
    wrong = (boresight_arcsec(rotation, frame) > WRONG_ARCSEC
             or wrong_stars(frame, catalog, obs_index, cat_vectors, camera) > 0)
    return True, bool(wrong)


def lost_in_space_rows(fov: float, args) -> list[dict]:
    solvers = Solvers(fov, args)
    junk = junk_frames(solvers.camera, args.frames, args.seed + 1)
    rows = []
    for turn, (label, kind, tolerance, err) in enumerate(paths(args.span)):
        each = {"startrack": solvers.ours(tolerance),
                **{name: solvers.peer(name, tolerance) for name in args.peers}}
        frames = junk if kind == "junk" else solvers.frames
        stats = {name: {"solved": 0, "wrong": 0, "ms": []} for name in each}
        for i, name in solve_order(len(frames), list(each), args.order, turn):
            est_ours, est_peer = told(fov, args.span, kind, err, i)
            answer, ms = each[name].solve(frames[i],
                                          est_ours if name == "startrack" else est_peer)
            solved, wrong = score(answer, frames[i], solvers.catalog, solvers.camera)
            s = stats[name]
            s["solved"] += solved
            s["wrong"] += wrong
            s["ms"].append(ms)
        row = {"fov": f"{fov:g}", "path": label, "frames": len(frames)}
        for name, s in stats.items():
            row |= {f"{name}_solved": s["solved"], f"{name}_wrong": s["wrong"],
                    f"{name}_ms": float(np.median(s["ms"]))}
        rows.append(row)
        print(line(row, args.peers), flush=True)
    return rows


def solve_order(n_frames: int, names: list[str], order: str,
                turn: int = 0) -> list[tuple[int, str]]:
    """(frame, solver) in the order they are solved: ``interleaved``, each frame by every
    solver in turn (each solve starts with the caches the others left); ``batch``, every
    frame by one solver, then by the next (its caches as a batch of inputs or a tracker
    leaves them), starting with solver ``turn`` (rotated row by row, so that none always
    goes first)."""
    if order == "interleaved":
        return [(i, name) for i in range(n_frames) for name in names]
    first = turn % len(names)
    return [(i, name) for name in names[first:] + names[:first] for i in range(n_frames)]


def tracking_rows(args) -> list[dict]:
    """The tracking sequence: (tracked, lost in space) for each solver."""
    summary = sequence_summary(args.track_frames, args.seed,
                               args.order == "interleaved").set_index("method")
    rows = []
    for label, ours, peer in (("tracking (tracked frames)", "pyramid+track", "tetra3rs+hint"),
                              ("tracking's lost in space", "pyramid", "tetra3rs")):
        row = {"fov": "20", "path": label, "frames": int(summary.loc[ours, "frames"])}
        for name, method in (("startrack", ours), ("tetra3rs", peer)):
            if method not in summary.index:
                continue
            r = summary.loc[method]
            row |= {f"{name}_solved": int(round(r["solved_rate"] * r["frames"])),
                    f"{name}_wrong": int(r["wrong"]), f"{name}_ms": float(r["time_median_ms"])}
        rows.append(row)
        print(line(row, args.peers), flush=True)
    return rows


def ratio(row: dict, peer: str = "tetra3rs") -> str:
    if f"{peer}_ms" not in row or row[f"{peer}_ms"] <= 0:
        return "-"
    return f"{row['startrack_ms'] / row[f'{peer}_ms']:.2f}x"


def line(row: dict, peers=DEFAULT_PEERS) -> str:
    parts = [f"{row['fov']:>4} deg  {row['path']:38s}"]
    for name in ("startrack", *peers):
        if f"{name}_ms" in row:
            parts.append(f"{name} {row[name + '_solved']}/{row['frames']} wrong "
                         f"{row[name + '_wrong']} {row[name + '_ms']:.3f} ms")
    return "  ".join(parts + [f"/ {peer} {ratio(row, peer)}" for peer in peers])


def table(rows: list[dict], peers=DEFAULT_PEERS) -> str:
    """The rows as markdown, a column group for startrack and each of ``peers``."""
    solvers = ("startrack", *peers)
    cols = [f"{name} {what}" for name in solvers for what in ("solved", "wrong", "median ms")]
    cols += [f"startrack / {peer}" for peer in peers]
    head = ["| FOV (deg) | path | frames | " + " | ".join(cols) + " |",
            "|" + "---|" * (3 + len(cols))]
    body = []
    for r in rows:
        cells = [r["fov"], r["path"], str(r["frames"])]
        for name in solvers:
            cells += ([str(r[f"{name}_solved"]), str(r[f"{name}_wrong"]),
                       f"{r[f'{name}_ms']:.3f}"] if f"{name}_ms" in r else ["-"] * 3)
        body.append("| " + " | ".join(cells + [ratio(r, peer) for peer in peers]) + " |")
    return "\n".join(head + body)


def doc_marker(order: str, peers) -> str:
    """The name of the doc section a run writes: one per order, and one more for a run
    with other peers than the default (``bench_paths interleaved``, ``bench_paths with
    tetra3rs,astrometry.net``)."""
    mark = "bench_paths" if order == "batch" else f"bench_paths {order}"
    return mark if tuple(peers) == DEFAULT_PEERS else f"{mark} with {','.join(peers)}"


def add_solver_options(ap) -> None:
    """The true widths of the frames, startrack's method and the per-frame limit, as
    this bench and bench_floor.py take them."""
    ap.add_argument("--fovs", default="11.4,20,30", help="comma-separated true widths, deg")
    ap.add_argument("--method", default=DEFAULT_METHOD, help="startrack's --method")
    ap.add_argument("--timeout-ms", type=float, default=5000.0,
                    help="wall-clock limit per frame, the same for every solver")


def main() -> None:
    ap = script_parser(__doc__)
    add_frames(ap, 10, seed=7)
    add_solver_options(ap)
    ap.add_argument("--span", type=float, default=1.7,
                    help="the blind range is [FOV / span, FOV x span] (at most 1.73: "
                         "startrack's --fov-tolerance stops at 0.5)")
    ap.add_argument("--track-frames", type=int, default=200, help="frames of the sequence")
    ap.add_argument("--peers", default=",".join(DEFAULT_PEERS),
                    help="the peers run beside startrack (each an installed solver)")
    ap.add_argument("--order", choices=ORDERS, default="batch",
                    help="batch: each solver solves a row's frames back to back (as a batch "
                         "or a tracker runs); interleaved: each frame by every solver in "
                         "turn (every solve starts with the caches the others left)")
    ap.add_argument("--doc", type=Path, help="write the table between this doc's markers")
    args = ap.parse_args()
    args.peers = [name for name in args.peers.split(",") if name]
    unknown = set(args.peers) - set(PEERS)
    if unknown:
        ap.error(f"--peers: unknown {sorted(unknown)} (known: {', '.join(PEERS)})")
    started = dt.datetime.now(dt.UTC).strftime("%Y-%m-%d %H:%M")
    load0, t0 = os.getloadavg()[0], time.perf_counter()
    rows = [r for fov in floats(args.fovs) for r in lost_in_space_rows(fov, args)]
    rows += tracking_rows(args)
    text = table(rows, args.peers)
    print(text)
    if args.doc:
        head = provenance_line("bench_paths.py", started, (time.perf_counter() - t0) / 60.0,
                               (load0, os.getloadavg()[0]))
        mark = doc_marker(args.order, args.peers)
        write_between(args.doc, f"<!-- {mark}:start -->", f"<!-- {mark}:end -->",
                      f"{head} {', '.join(args.peers)} from the peers' venv; startrack "
                      f"--method {args.method}; frames solved in {args.order} order."
                      f"\n\n{text}")


if __name__ == "__main__":
    main()
