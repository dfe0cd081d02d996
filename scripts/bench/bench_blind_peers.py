"""Blind-solve bench beside the peers: startrack, tetra3, tetra3rs and astrometry.net on
bench_blind.py's frames, given the same information: a FOV estimate off by 0, 2, 5 or 10 %
(``--errors``; half the frames above, half below) with the same range searched about it,
or no FOV at all. A peer that is not installed is skipped with a one-line note.

* startrack: ``Options(fov_deg=estimate, fov_tolerance=0.10)`` (it searches
  estimate x (1 +- 10 %) widened by startrack.solver._fov_search.MARGIN), or no FOV (its blind
  search of
  startrack.defaults.BLIND_FOV_RANGE on its default sky with no camera: Tycho-2 when
  installed, else Gaia).
* tetra3 and tetra3rs: the same estimate with ``fov_max_error`` the half-width startrack
  searches, on one database per FOV spanning every estimate's range; no FOV: their own
  unknown-FOV mode (tetra3: ``fov_estimate=None``; tetra3rs has none, so the centre of its
  database range with the whole range as the error) on a database over
  [FOV / ``--peer-span``, FOV x ``--peer-span``], narrower than startrack's 0.8 to 40 deg,
  which here takes too long to build: more information than startrack gets.
* astrometry.net (``solve-field`` on the centroid list, scripts/bench/bench_blind_peer_solvers.py):
  the same searched range as ``--scale-low/--scale-high`` in image widths; no FOV: no
  scale at all (its own blind search over its Tycho-2 index files); ``--cpulimit`` the
  per-frame limit. Its time is the ``solve-field`` process's wall time, which includes
  loading its index files (it has no way to keep them loaded between calls).
* Every solver has the same wall-clock limit per frame (``--timeout-ms``); each frame is
  solved by the three in turn, so the machine's load falls on all alike. Loading (their
  databases, our tables: one junk frame is solved untimed first) is not timed.
* wrong: boresight more than 60" from the truth, or a named star that is not the true
  star there (bench_blind.wrong_stars). Times: the solve call; median and p95.

    PYTHONPATH=. /work/peers-venv/bin/python scripts/bench/bench_blind_peers.py \
        [--frames 8] [--fovs 11.4,20] [--doc docs/blind.md]

With ``--doc`` the table, the command, commit, date and load average replace what is
between the doc's ``<!-- bench_blind_peers:start -->`` and ``:end -->`` markers (or
``--section``'s). ``--peers`` picks the peers (default: all).
"""

from __future__ import annotations

import dataclasses
import datetime as dt
import os
import sys
import time
from pathlib import Path

import numpy as np

from scripts._cli import script_parser  # noqa: E402
from scripts.bench.bench_blind import (  # noqa: E402
    WRONG_ARCSEC,
    add_grid_options,
    boresight_arcsec,
    floats,
    frames_for,
    junk_input,
    provenance_line,
    write_between,
    wrong_stars,
)
from scripts.bench.bench_blind_peer_solvers import PEERS  # noqa: E402
from startrack.centroids import Centroids  # noqa: E402
from startrack.defaults import DEFAULT_METHOD  # noqa: E402
from startrack.errors import InputError  # noqa: E402
from startrack.sky import CATALOG_EPOCH  # noqa: E402
from startrack.solver import (  # noqa: E402
    MARGIN,  # noqa: E402
    FrameInput,
    Options,
    Pipeline,
)

TOLERANCE = 0.10  # startrack's --fov-tolerance unless --tolerance says otherwise


#: the peers' half-width when startrack is told the FOV exactly (tolerance 0): tetra3rs
#: solves nothing with a zero error, so they get this much (0.1 deg of 20)
EXACT_HALF_WIDTH = 0.005


def search_half_width(tolerance: float) -> float:
    """The half-width (a fraction of the estimate) of the FOVs startrack searches at
    ``tolerance``: the peers' fov_max_error (:data:`EXACT_HALF_WIDTH` for an exact FOV)."""
    if tolerance <= 0:
        return EXACT_HALF_WIDTH
    return (1.0 + tolerance) * (1.0 + MARGIN) - 1.0
SOLVERS = ("startrack", "tetra3", "tetra3rs", "astrometry")


def estimate(fov: float, err: float | None, i: int) -> float | None:
    return None if err is None else fov * (1.0 + (1.0 if i % 2 == 0 else -1.0) * err / 100.0)


class Ours:
    """startrack through its pipeline, one per estimate (loaded once, warmed on junk)."""

    def __init__(self, camera, sky_kind: str, timeout_ms: float, tolerance: float,
                 method: str = DEFAULT_METHOD) -> None:
        self.camera, self.timeout_ms, self.tolerance = camera, timeout_ms, tolerance
        self.method = method
        # a blind search uses Gaia: carried to the epoch of the (Hipparcos) frames
        self.epoch = CATALOG_EPOCH if sky_kind == "hipparcos" else None
        self._pipelines: dict[float | None, Pipeline] = {}

    def pipeline(self, est: float | None) -> Pipeline:
        if est not in self._pipelines:
            size = (self.camera.width, self.camera.height)
            options = Options(fov_deg=est, size=size, fov_tolerance=self.tolerance,
                              method=self.method,
                              epoch=None if est is not None else self.epoch)
            pipeline = Pipeline(options)
            pipeline.solve(junk_input(size))  # every table loaded, untimed, no limit
            pipeline.options = dataclasses.replace(options, timeout_ms=self.timeout_ms)
            self._pipelines[est] = pipeline
        return self._pipelines[est]

    def solve(self, frame, est: float | None):
        pipeline = self.pipeline(est)
        flux = np.arange(len(frame.obs), 0, -1, dtype=float)  # brightest first, as observed
        inp = FrameInput("sim", Centroids(frame.obs.x, frame.obs.y, flux))
        t0 = time.perf_counter()
        result = pipeline.solve(inp)
        ms = (time.perf_counter() - t0) * 1000.0
        sol = result.solution
        if not sol.solved:
            return None, ms
        return (sol.rotation, sol.obs_index, result.catalog.vectors[sol.cat_index]), ms


def run(args) -> list[dict]:
    errors = floats(args.errors)
    settings = [(f"{e:g}%", e) for e in errors] + ([] if args.no_blind else [("no FOV", None)])
    rows = []
    for fov in floats(args.fovs):
        camera, frames, catalog = frames_for(fov, args.frames, args.seed, with_catalog=True)
        kind = catalog.source["kind"]
        solvers = {"startrack": Ours(camera, kind, args.timeout_ms, args.tolerance,
                                     args.method)}
        for name, make in PEERS.items():
            if name not in args.peers.split(","):
                continue
            try:
                solvers[name] = make(catalog, camera, fov, search_half_width(args.tolerance),
                                     args.tolerance, args.peer_span, args.timeout_ms)
            except (ImportError, InputError) as exc:
                print(f"skipping {name}: {str(exc).splitlines()[0]}", file=sys.stderr)
        names = [n for n in SOLVERS if n in solvers]
        for label, err in settings:
            stats = {name: {"solved": 0, "wrong": 0, "pointing": 0, "ms": []}
                     for name in names}
            for i, frame in enumerate(frames):
                est = estimate(fov, err, i)
                for name in names:
                    answer, ms = solvers[name].solve(frame, est)
                    s = stats[name]
                    s["ms"].append(ms)
                    if answer is not None:
                        rotation, obs_index, cat_vectors = answer
                        pointing = boresight_arcsec(rotation, frame) > WRONG_ARCSEC
                        s["solved"] += 1
                        s["pointing"] += pointing
                        s["wrong"] += bool(pointing or wrong_stars(frame, catalog, obs_index,
                                                                   cat_vectors, camera))
            row = {"fov": fov, "given": label, "frames": len(frames)}
            for name in names:
                s = stats[name]
                row |= {f"{name}_solved": s["solved"], f"{name}_wrong": s["wrong"],
                        f"{name}_pointing": s["pointing"],
                        f"{name}_median_ms": float(np.median(s["ms"])),
                        f"{name}_p95_ms": float(np.percentile(s["ms"], 95))}
            rows.append(row)
            print("  ".join([f"fov {fov:5.1f} given {label:7s}"] + [
                f"{n} {row[n + '_solved']}/{len(frames)} wrong {row[n + '_wrong']} "
                f"({row[n + '_pointing']}) "
                f"{row[n + '_median_ms']:.0f}/{row[n + '_p95_ms']:.0f} ms" for n in names]),
                flush=True)
    return rows


def table(rows: list[dict]) -> str:
    """The rows as a markdown table, one column group per solver that ran (a solver not
    installed for some FOV gets dashes there)."""
    names = [n for n in SOLVERS if any(f"{n}_solved" in r for r in rows)]
    head = "| FOV (deg) | FOV given | " + " | ".join(
        f"{n} solved | {n} wrong (pointing) | {n} median ms | {n} p95 ms" for n in names) \
        + " |"
    lines = [head, "|" + "---|" * (2 + 4 * len(names))]
    for r in rows:
        cells = [f"{r['fov']:g}", r["given"]]
        for n in names:
            if f"{n}_solved" not in r:
                cells += ["-"] * 4
                continue
            cells += [f"{r[n + '_solved']}/{r['frames']}",
                      f"{r[n + '_wrong']} ({r[n + '_pointing']})",
                      _ms(r[n + "_median_ms"]), _ms(r[n + "_p95_ms"])]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _ms(value: float) -> str:
    # sub-millisecond medians to 0.01 ms: their ratios are what the bench is read for
    return f"{value:.2f}" if value < 1 else f"{value:.1f}" if value < 10 else f"{value:.0f}"


def main() -> None:
    ap = script_parser(__doc__)
    add_grid_options(ap, "11.4,20")
    ap.add_argument("--no-blind", action="store_true", help="skip the no-FOV setting")
    ap.add_argument("--tolerance", type=float, default=TOLERANCE,
                    help="startrack's --fov-tolerance; the peers' fov_max_error follows it "
                         "(0: the FOV declared exact)")
    ap.add_argument("--method", default=DEFAULT_METHOD,
                    help="startrack's --method (default: the CLI's); quad is scale-free: "
                         "with a nominal FOV it goes straight to the focal-length search")
    ap.add_argument("--timeout-ms", type=float, default=5000.0,
                    help="wall-clock limit per frame, the same for every solver")
    ap.add_argument("--peer-span", type=float, default=2.0,
                    help="the peers' no-FOV database covers [FOV / span, FOV x span]")
    ap.add_argument("--peers", default=",".join(PEERS), help="the peers to run beside startrack")
    ap.add_argument("--doc", type=Path, help="write the table between this doc's markers")
    ap.add_argument("--section", default="bench_blind_peers",
                    help="the doc's markers: <!-- SECTION:start --> ... <!-- SECTION:end -->")
    args = ap.parse_args()
    started = dt.datetime.now(dt.UTC).strftime("%Y-%m-%d %H:%M")
    load0, t0 = os.getloadavg()[0], time.perf_counter()
    rows = run(args)
    print(table(rows))
    if args.doc:
        line = provenance_line("bench_blind_peers.py", started,
                               (time.perf_counter() - t0) / 60.0, (load0, os.getloadavg()[0]))
        write_between(args.doc, f"<!-- {args.section}:start -->",
                      f"<!-- {args.section}:end -->", (
            f"{line} Run with the peers' venv (`PYTHONPATH=. /work/peers-venv/bin/python`).\n"
            "wrong: frames with a wrong pointing or a wrong star; (pointing): of them, "
            "those whose boresight is more than 60\" off. FOV search half-width given to "
            f"the peers: {search_half_width(args.tolerance):.3f} of the estimate (startrack's "
            f"--fov-tolerance {args.tolerance:g}, --method {args.method}); per-frame limit "
            f"{args.timeout_ms:g} ms."
            f"\n\n{table(rows)}"))


if __name__ == "__main__":
    main()
