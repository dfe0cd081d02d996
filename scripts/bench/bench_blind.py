"""Blind-solve bench: solved rate, wrong answers and time against the error of the given FOV
(0, 2, 5, 10 %) and with no FOV at all, on simulated frames of several cameras.

Frames are the bench's (startrack.bench._frames.make_frame): true stars of the default sky
for each camera (gaia below 8 deg, hipparcos above) with centroid noise, dropouts, false
stars and magnitude noise (so the brightness order is not the catalog's). Each frame is
solved through the pipeline (startrack.solver._fov_search) given the FOV times (1 + error), half of
the
frames with the error positive and half negative, and with no FOV. A solution is wrong
when its boresight is more than 60 arcsec from the truth. With ``--peers`` tetra3 and
tetra3rs are run on the same frames given the same FOV estimate and a maximum error of
the same size (tolerance 10 %, or the whole range when blind); run that with
``PYTHONPATH=. /work/peers-venv/bin/python scripts/bench/bench_blind.py --peers``.

    .venv/bin/python scripts/bench/bench_blind.py [--frames 8] [--fovs 2,5,11.4,20,30]
"""

from __future__ import annotations

import argparse
import datetime as dt
import math
import os
import shlex
import sys
import time
from pathlib import Path

import numpy as np

from scripts._cli import add_frames, script_parser
from startrack.bench import Condition, git_commit, make_frame
from startrack.camera import Camera
from startrack.centroids import Centroids
from startrack.sky import UNRESOLVED_PIXELS, SkySpec, default_sky_kind, load_sky, resolve_sky
from startrack.solver import FrameInput, Options, Pipeline

CONDITION = Condition(noise_px=0.3, false_stars=3, missing=0.05, mag_noise=0.3)
WRONG_ARCSEC = 60.0
SIZES = {True: (1024, 768), False: (1280, 1024)}
MIN_REAL_STARS = 6
START, END = "<!-- bench_blind:start -->", "<!-- bench_blind:end -->"


def frames_for(fov: float, n: int, seed: int, with_catalog: bool = False):
    """``n`` bench frames of a camera with horizontal FOV ``fov`` (its default sky)."""
    width, height = SIZES[fov < 15]
    camera = Camera.from_fov(width, height, fov)
    spec = resolve_sky(SkySpec(kind=default_sky_kind(camera)), camera)
    catalog = load_sky(spec, camera)
    frames = [make_frame(catalog, camera, CONDITION, seed, i) for i in range(n)]
    return (camera, frames, catalog) if with_catalog else (camera, frames)


def wrong_stars(frame, catalog, obs_index: np.ndarray, cat_vectors: np.ndarray,
                camera: Camera) -> int:
    """How many of a solution's named stars are not the frame's true star there: a false
    star given a name, or a catalog direction farther from the true star's than the camera
    can split (the merge separation, 2 px: the catalogs of a solver may differ from the
    frames', e.g. Gaia for a blind search on Hipparcos frames)."""
    truth = frame.truth_rows[np.asarray(obs_index, dtype=np.int64)]
    real = truth >= 0
    true_v = catalog.vectors[np.where(real, truth, 0)]
    cos = np.clip(np.einsum("ij,ij->i", true_v, np.asarray(cat_vectors, float)), -1.0, 1.0)
    far = np.degrees(np.arccos(cos)) > math.degrees(UNRESOLVED_PIXELS / camera.f_px)
    return int(np.count_nonzero(~real | far))


def boresight_arcsec(rotation, frame) -> float:
    b, t = rotation.apply([0.0, 0.0, 1.0]), frame.rotation.apply([0.0, 0.0, 1.0])
    return math.degrees(math.acos(min(1.0, float(b @ t)))) * 3600.0


def junk_input(size: tuple[int, int], n: int = 40, seed: int = 0) -> FrameInput:
    """Random points: a frame that no search solves, so solving it once loads every table
    a search may need (outside the timed solves)."""
    rng = np.random.default_rng(seed)
    return FrameInput("junk", Centroids(rng.uniform(0, size[0] - 1, n),
                                        rng.uniform(0, size[1] - 1, n),
                                        np.arange(n, 0, -1.0)))


def solve_ours(pipeline: Pipeline, frame):
    """The pipeline's result for a bench frame (None if not solved) and its time in ms."""
    obs = frame.obs
    flux = np.arange(len(obs), 0, -1, dtype=float)  # brightest first, as observed
    inp = FrameInput("sim", Centroids(obs.x, obs.y, flux))
    t0 = time.perf_counter()
    result = pipeline.solve(inp)
    ms = (time.perf_counter() - t0) * 1000.0
    return (result if result.solution.solved else None), ms


def run(fovs, errors, n, seed) -> list[dict]:
    rows = []
    for fov in fovs:
        camera, frames, catalog = frames_for(fov, n, seed, with_catalog=True)
        size = (camera.width, camera.height)
        # a frame can be verified only with a pattern (4 stars) and 2 more stars to confirm
        enough = sum(int(np.count_nonzero(f.truth_rows >= 0)) >= MIN_REAL_STARS
                     for f in frames)
        settings = [(f"{e:g}%", e) for e in errors] + [("no FOV", None)]
        for label, err in settings:
            solved = wrong = 0
            times, fov_err = [], []
            for i, frame in enumerate(frames):
                if err is None:
                    options = Options(size=size)
                else:
                    sign = 1.0 if i % 2 == 0 else -1.0
                    options = Options(fov_deg=fov * (1.0 + sign * err / 100.0), size=size)
                result, ms = solve_ours(_pipeline(options), frame)
                times.append(ms)
                if result is not None:
                    sol = result.solution
                    solved += 1
                    wrong += bool(boresight_arcsec(sol.rotation, frame) > WRONG_ARCSEC
                                  or wrong_stars(frame, catalog, sol.obs_index,
                                                 result.catalog.vectors[sol.cat_index],
                                                 camera))
                    fov_err.append(abs(result.camera.fov_deg - fov))
            rows.append({"fov": fov, "given": label, "solved": solved, "wrong": wrong,
                         "frames": n, "enough": enough, "median_ms": float(np.median(times)),
                         "max_ms": float(np.max(times)),
                         "fov_err": float(np.max(fov_err)) if fov_err else float("nan")})
            print(f"fov {fov:5.1f}  given {label:7s}  solved {solved}/{n}  wrong {wrong}  "
                  f"(>= {MIN_REAL_STARS} real stars: {enough})  "
                  f"median {rows[-1]['median_ms']:7.0f} ms  max {rows[-1]['max_ms']:7.0f} ms  "
                  f"max |fov error| {rows[-1]['fov_err']:.4f} deg", flush=True)
    return rows


_PIPELINES: dict = {}


def _pipeline(options: Options) -> Pipeline:
    """One pipeline per told FOV (databases shared per camera), its tables loaded by one
    untimed junk frame."""
    key = (options.fov_deg, options.size)
    if key not in _PIPELINES:
        _PIPELINES[key] = Pipeline(options)
        _PIPELINES[key].solve(junk_input(options.size))
    return _PIPELINES[key]


def write_between(doc: Path, start: str, end: str, body: str) -> None:
    """Replace what is between the ``start`` and ``end`` markers of ``doc`` (atomically)."""
    text = doc.read_text()
    if start not in text or end not in text:
        raise SystemExit(f"{doc} has no {start} ... {end} markers")
    head, rest = text.split(start, 1)
    tail = rest.split(end, 1)[1]
    tmp = doc.with_name(doc.name + ".tmp")
    tmp.write_text(f"{head}{start}\n{body}\n{end}{tail}")
    tmp.replace(doc)


def provenance_line(script: str, started: str, minutes: float, load) -> str:
    full = git_commit() or "?"
    commit = full[:10] + ("+dirty" if full.endswith("+dirty") else "")
    return (f"<!-- written by scripts/bench/{script}: do not edit by hand -->\n"
            f"`{shlex.join(['scripts/bench/' + script, *sys.argv[1:]])}` at commit `{commit}`, "
            f"started {started} UTC, {minutes:.1f} min; load average {load[0]:.1f} at the "
            f"start, {load[1]:.1f} at the end (2 cores).")


def table(rows: list[dict]) -> str:
    lines = ["| FOV (deg) | FOV given | solved | wrong | frames with >= "
             f"{MIN_REAL_STARS} real stars | median ms | max ms | max FOV error (deg) |",
             "|---|---|---|---|---|---|---|---|"]
    lines += [f"| {r['fov']:g} | {r['given']} | {r['solved']}/{r['frames']} | {r['wrong']} | "
              f"{r['enough']} | {r['median_ms']:.0f} | {r['max_ms']:.0f} | "
              f"{r['fov_err']:.4f} |" for r in rows]
    return "\n".join(lines)


def add_grid_options(ap: argparse.ArgumentParser, fovs: str) -> None:
    """The grid a blind benchmark runs over: ``--fovs`` (true field widths, deg), ``--errors``
    (how far off, in %, the FOV given is), ``--frames`` per cell and their ``--seed``."""
    add_frames(ap, 8, seed=7)
    ap.add_argument("--fovs", default=fovs, help="comma-separated true field widths, deg")
    ap.add_argument("--errors", default="0,2,5,10",
                    help="comma-separated errors of the FOV given, %%")


def floats(text: str) -> list[float]:
    """A comma-separated option's numbers."""
    return [float(v) for v in text.split(",")]


def main() -> None:
    ap = script_parser(__doc__)
    add_grid_options(ap, "2,5,11.4,20,30")
    ap.add_argument("--doc", type=Path, help="write the table between this doc's markers")
    args = ap.parse_args()
    fovs, errors = floats(args.fovs), floats(args.errors)
    started = dt.datetime.now(dt.UTC).strftime("%Y-%m-%d %H:%M")
    load0, t0 = os.getloadavg()[0], time.perf_counter()
    rows = run(fovs, errors, args.frames, args.seed)
    print(table(rows))
    if args.doc:
        line = provenance_line("bench_blind.py", started, (time.perf_counter() - t0) / 60.0,
                               (load0, os.getloadavg()[0]))
        write_between(args.doc, START, END, f"{line}\n\n{table(rows)}")


if __name__ == "__main__":
    main()
