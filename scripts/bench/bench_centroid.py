"""Print centroid accuracy, detection completeness and speed of ``extract_centroids``.

Frames come from the project's renderer (startrack.simulate._render / scene / sensor, default
SensorModel: PSF sigma 1 px, read noise 10 e-, 16-bit ADC), so the truth is exact.

1. RMS centroid error (px) against star signal (electrons), 1024 x 1024 frames with a
   grid of stars at random sub-pixel positions, with the photon-noise limit for reference.
2. Detection completeness against magnitude: random skies (magnitudes uniform in 4..10),
   20 deg field, random attitudes; detections within 1.5 px of a star count as found.
3. Time per frame (ms) on a rendered 1024 x 1024 frame and on a real-sky frame.
4. Time per frame as a user meets it: each real frame in a new process, whose first call
   of ``extract_centroids`` comes right after the import (no warm-up), beside the median
   of the calls after it (warm).

    .venv/bin/python scripts/bench/bench_centroid.py
    .venv/bin/python scripts/bench/bench_centroid.py --frames 20 --repeats 30
    .venv/bin/python scripts/bench/bench_centroid.py --fast      # the same for CentroidConfig.fast
    .venv/bin/python scripts/bench/bench_centroid.py --only-first-call --images DIR  # 4. only

Beside tetra3rs on the same pixels: scripts/bench/bench_centroid_peers.py.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from startrack.attitude import random_attitudes
from startrack.camera import Camera
from startrack.centroids import FAST, CentroidConfig
from startrack.centroids import extract_centroids as _extract
from startrack.io import read_image
from startrack.simulate import SensorModel, deposit_gaussians, digitise, observe, render_frame
from startrack.sky import random_sky

REAL_SKY = Path(__file__).resolve().parents[2] / "tests" / "data" / "realsky_azi45.png"
MATCH_PX = 1.5
CONFIG = CentroidConfig()


def extract_centroids(image):
    return _extract(image, CONFIG)


def nearest(found_x, found_y, x, y) -> tuple[np.ndarray, np.ndarray]:
    """Distance to, and index of, the nearest detection for each true star."""
    if len(found_x) == 0:
        return np.full(len(x), np.inf), np.zeros(len(x), int)
    return cKDTree(np.c_[found_x, found_y]).query(np.c_[x, y])


def accuracy_table(sensor: SensorModel, frames: int, rng: np.random.Generator) -> None:
    print("1. Centroid error against signal (1024 x 1024, grid of 81 stars per frame, "
          f"{frames} frames; PSF sigma {sensor.psf_sigma_px} px, read noise "
          f"{sensor.read_noise} e-, background {sensor.background_electrons:.1f} e-/px)")
    print(f"{'electrons':>10} {'peak SNR':>9} {'found':>7} {'RMS px':>8} {'bias x':>8} "
          f"{'bias y':>8} {'photon limit':>13} {'flux/true':>10}")
    grid = np.arange(1, 10) * 1024 / 10
    gx, gy = (a.ravel() for a in np.meshgrid(grid, grid))
    sigma = sensor.psf_sigma_px
    for e in (1e3, 3e3, 1e4, 3e4, 1e5):
        dx, dy, ratio, n_true = [], [], [], 0
        for _ in range(frames):
            x = gx + rng.uniform(-0.5, 0.5, gx.size)
            y = gy + rng.uniform(-0.5, 0.5, gy.size)
            expected = np.full((1024, 1024), sensor.background_electrons)
            deposit_gaussians(expected, x, y, np.full(x.size, e), sigma)
            image = digitise(expected, sensor, rng)
            found = extract_centroids(image)
            d, j = nearest(found.x, found.y, x, y)
            ok = d < MATCH_PX
            n_true += x.size
            dx.append(found.x[j[ok]] - x[ok])
            dy.append(found.y[j[ok]] - y[ok])
            ratio.append(found.flux[j[ok]] * sensor.gain / e)
        dx, dy, ratio = np.concatenate(dx), np.concatenate(dy), np.concatenate(ratio)
        peak = e / (2 * np.pi * sigma**2)
        snr = peak / np.sqrt(peak + sensor.background_electrons + sensor.read_noise**2)
        rms = np.sqrt(np.mean(dx**2 + dy**2)) if dx.size else np.nan
        limit = np.sqrt(2.0) * sigma / np.sqrt(e)  # radial, shot noise of the star only
        print(f"{e:>10.0e} {snr:>9.1f} {dx.size / n_true:>7.1%} {rms:>8.4f} "
              f"{np.mean(dx):>8.4f} {np.mean(dy):>8.4f} {limit:>13.4f} "
              f"{np.median(ratio):>10.3f}")


def completeness_table(sensor: SensorModel, frames: int, rng: np.random.Generator) -> None:
    camera = Camera.from_fov(1024, 1024, 20.0)
    # growth ~1 per magnitude: magnitudes nearly uniform, so every bin has enough stars
    catalog = random_sky(n_stars=20000, seed=3, mag_min=4.0, mag_max=10.0,
                         growth_per_mag=1.0001)
    mags, hit, n_found, n_spurious = [], [], 0, 0
    for rotation in random_attitudes(frames, rng):
        scene = observe(catalog, camera, rotation, rng)
        found = extract_centroids(render_frame(scene, camera, sensor, rng))
        d, _ = nearest(found.x, found.y, scene.x, scene.y)
        mags.append(scene.mag)
        hit.append(d < MATCH_PX)
        n_found += len(found)
        if len(scene.x):
            d_back, _ = nearest(scene.x, scene.y, found.x, found.y)
            n_spurious += int(np.count_nonzero(d_back >= MATCH_PX))
    mags, hit = np.concatenate(mags), np.concatenate(hit)
    e_at = sensor.electrons_from_mag
    print(f"\n2. Detection completeness against magnitude ({frames} frames, 20 deg FOV, "
          f"1024 x 1024, {len(mags)} stars in view)")
    print(f"{'mag':>9} {'electrons':>10} {'stars':>6} {'found':>7}")
    edges = np.arange(4.0, 10.01, 0.5)
    for lo, hi in zip(edges[:-1], edges[1:], strict=True):
        sel = (mags >= lo) & (mags < hi)
        if sel.any():
            print(f"{lo:>4.1f}-{hi:<4.1f} {e_at((lo + hi) / 2):>10.0f} {sel.sum():>6} "
                  f"{hit[sel].mean():>7.1%}")
    print(f"detections: {n_found}, not within {MATCH_PX} px of any star: {n_spurious}")


def timing_table(sensor: SensorModel, repeats: int, rng: np.random.Generator) -> None:
    camera = Camera.from_fov(1024, 1024, 20.0)
    catalog = random_sky(n_stars=5000, seed=4, mag_max=7.5)
    scene = observe(catalog, camera, random_attitudes(1, rng)[0], rng)
    frames = {"rendered 1024 x 1024": render_frame(scene, camera, sensor, rng)}
    if REAL_SKY.exists():
        frames["real sky 1024 x 768"] = read_image(REAL_SKY)
    print(f"\n3. Time of extract_centroids ({repeats} runs; the best is the least disturbed "
          "by other load)")
    for name, image in frames.items():
        extract_centroids(image)  # warm-up (imports, allocations)
        times = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            found = extract_centroids(image)
            times.append(time.perf_counter() - t0)
        print(f"{name:>22}: median {1e3 * np.median(times):6.1f} ms, best "
              f"{1e3 * np.min(times):6.1f} ms  ({len(found)} centroids)")


# Run in a new process: the import is timed apart, then the first call, then warm calls.
_FIRST_CALL = """
import json, sys, time
import numpy as np
from startrack.io._images import read_image
image = read_image(sys.argv[1])
t0 = time.perf_counter()
from startrack.centroids._extract import FAST, CentroidConfig, extract_centroids
t1 = time.perf_counter()
config = FAST if sys.argv[3] == "fast" else CentroidConfig()
c1 = time.process_time()
found = extract_centroids(image, config)
t2, c2 = time.perf_counter(), time.process_time()
warm, warm_cpu = [], []
for _ in range(int(sys.argv[2])):
    t, c = time.perf_counter(), time.process_time()
    extract_centroids(image, config)
    warm.append(time.perf_counter() - t)
    warm_cpu.append(time.process_time() - c)
print(json.dumps({"import": t1 - t0, "first": t2 - t1, "warm": float(np.median(warm)),
                  "first_cpu": c2 - c1, "warm_cpu": float(np.median(warm_cpu)),
                  "n": len(found), "numba": "numba" in sys.modules}))
"""


def first_call_table(images: list[Path], repeats: int, fast: bool) -> None:
    print(f"\n4. extract_centroids in a new process per frame: its import, its first call "
          f"(no warm-up), and the median of {repeats} calls after it; wall-clock, and the "
          "CPU time of the process (all its threads), which load on the machine does not "
          "inflate")
    print(f"{'frame':>44} {'import ms':>10} {'first ms':>9} {'warm ms':>8} {'first cpu':>10} "
          f"{'warm cpu':>9} {'stars':>6}")
    for path in images:
        run = subprocess.run([sys.executable, "-c", _FIRST_CALL, str(path), str(repeats),
                              "fast" if fast else "full"], capture_output=True, text=True,
                             check=True)
        r = json.loads(run.stdout)
        print(f"{path.name:>44} {1e3 * r['import']:>10.1f} {1e3 * r['first']:>9.1f} "
              f"{1e3 * r['warm']:>8.1f} {1e3 * r['first_cpu']:>10.1f} "
              f"{1e3 * r['warm_cpu']:>9.1f} {r['n']:>6}"
              + ("  (numba loaded)" if r["numba"] else ""))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=8, help="frames per table row")
    parser.add_argument("--repeats", type=int, default=15, help="timing repeats")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--fast", action="store_true", help="CentroidConfig(fast=True)")
    parser.add_argument("--images", type=Path, default=None,
                        help="folder of real frames (*.tif*, *.png) for table 4 (default: "
                             "the test frame)")
    parser.add_argument("--only-first-call", action="store_true", help="table 4 only")
    args = parser.parse_args()
    images = [REAL_SKY] if args.images is None else sorted(
        p for p in args.images.iterdir() if p.suffix.lower() in (".tif", ".tiff", ".png"))
    global CONFIG
    CONFIG = FAST if args.fast else CentroidConfig()
    print(f"extract_centroids with {CONFIG}")
    if args.only_first_call:
        first_call_table(images, args.repeats, args.fast)
        return
    rng = np.random.default_rng(args.seed)
    sensor = SensorModel()
    accuracy_table(sensor, args.frames, rng)
    completeness_table(sensor, args.frames, rng)
    timing_table(sensor, args.repeats, rng)
    first_call_table(images, args.repeats, args.fast)


if __name__ == "__main__":
    main()
