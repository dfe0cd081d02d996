"""Blind-solve bench: solved rate, wrong answers and time against the error of the given FOV
(0, 2, 5, 10 %) and with no FOV at all, on simulated frames of several cameras.

Frames are the bench's (startrack.bench.frames.make_frame): true stars of the default sky
for each camera (gaia below 8 deg, hipparcos above) with centroid noise, dropouts, false
stars and magnitude noise (so the brightness order is not the catalog's). Each frame is
solved through the pipeline (startrack.fov) given the FOV times (1 + error), half of the
frames with the error positive and half negative, and with no FOV. A solution is wrong
when its boresight is more than 60 arcsec from the truth. With ``--peers`` tetra3 and
tetra3rs are run on the same frames given the same FOV estimate and a maximum error of
the same size (tolerance 10 %, or the whole range when blind); run that with
``PYTHONPATH=. /work/peers-venv/bin/python scripts/bench_blind.py --peers``.

    .venv/bin/python scripts/bench_blind.py [--frames 8] [--fovs 2,5,11.4,20,30]
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from startrack.bench.conditions import Condition
from startrack.bench.frames import make_frame
from startrack.camera import Camera
from startrack.centroids import Centroids
from startrack.pipeline import FrameInput, Options, Pipeline
from startrack.sky import UNRESOLVED_PIXELS, SkySpec, default_sky_kind, load_sky, resolve_sky

CONDITION = Condition(noise_px=0.3, false_stars=3, missing=0.05, mag_noise=0.3)
WRONG_ARCSEC = 60.0
SIZES = {True: (1024, 768), False: (1280, 1024)}


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


def solve_ours(pipeline: Pipeline, frame, camera: Camera):
    obs = frame.obs
    flux = np.arange(len(obs), 0, -1, dtype=float)  # brightest first, as observed
    inp = FrameInput("sim", Centroids(obs.x, obs.y, flux))
    t0 = time.perf_counter()
    result = pipeline.solve(inp)
    ms = (time.perf_counter() - t0) * 1000.0
    sol = result.solution
    if not sol.solved:
        return False, None, ms, None
    b = sol.rotation.apply([0.0, 0.0, 1.0])
    t = frame.rotation.apply([0.0, 0.0, 1.0])
    err = math.degrees(math.acos(min(1.0, float(b @ t)))) * 3600.0
    return True, err, ms, result.camera.fov_deg


def run(fovs, errors, n, seed) -> list[dict]:
    rows = []
    for fov in fovs:
        camera, frames = frames_for(fov, n, seed)
        size = (camera.width, camera.height)
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
                ok, off, ms, fitted = solve_ours(_pipeline(options), frame, camera)
                times.append(ms)
                if ok:
                    solved += 1
                    wrong += off > WRONG_ARCSEC
                    fov_err.append(abs(fitted - fov))
            rows.append({"fov": fov, "given": label, "solved": solved, "wrong": wrong,
                         "frames": n, "median_ms": float(np.median(times)),
                         "max_ms": float(np.max(times)),
                         "fov_err": float(np.max(fov_err)) if fov_err else float("nan")})
            print(f"fov {fov:5.1f}  given {label:7s}  solved {solved}/{n}  wrong {wrong}  "
                  f"median {rows[-1]['median_ms']:7.0f} ms  max {rows[-1]['max_ms']:7.0f} ms  "
                  f"max |fov error| {rows[-1]['fov_err']:.4f} deg", flush=True)
    return rows


_PIPELINES: dict = {}


def _pipeline(options: Options) -> Pipeline:
    key = (options.fov_deg, options.size)  # the loaded databases are shared per camera
    if key not in _PIPELINES:
        _PIPELINES[key] = Pipeline(options)
    return _PIPELINES[key]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=8)
    ap.add_argument("--fovs", default="2,5,11.4,20,30")
    ap.add_argument("--errors", default="0,2,5,10")
    ap.add_argument("--seed", type=int, default=7)
    args = ap.parse_args()
    fovs = [float(v) for v in args.fovs.split(",")]
    errors = [float(v) for v in args.errors.split(",")]
    run(fovs, errors, args.frames, args.seed)


if __name__ == "__main__":
    main()
