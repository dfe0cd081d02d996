"""Calibration bench: `startrack calibrate`'s fit from a wrong nominal camera.

Simulated: frames through a 20 deg 1024 x 1024 lens with k1 = -0.3 (the bench's seeded
frames, startrack.bench._frames, from centroids with noise or rendered images), calibrated
from a pinhole camera whose FOV is 4% too wide and 4% too narrow. Real: the four frames of
shared/real-sky (11.42 deg, Hipparcos at epoch 2019.6) from nominal FOVs 11.0, 11.42, 12.0.
Prints the fitted FOV, k1 and principal point, and the residual RMS before and after.

    .venv/bin/python scripts/bench/bench_calibrate.py --frames 8
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from startrack.bench import Condition, make_frame, true_camera
from startrack.camera import Camera
from startrack.centroids import Centroids
from startrack.sky import SkySpec, load_sky, resolve_sky
from startrack.solver import FrameInput, calibrate, read_input

REAL_SKY = Path(__file__).resolve().parents[2].parent.parent / "shared" / "real-sky"
REAL_FOV = 11.42


def _simulated(args) -> None:
    camera = Camera.from_fov(1024, 1024, 20.0)
    condition = Condition(noise_px=args.noise_px, distortion_k1=args.k1)
    lens = true_camera(camera, condition)
    catalog = load_sky(resolve_sky(SkySpec(kind="hipparcos"), camera), camera)
    frames = []
    for i in range(args.frames):
        bf = make_frame(catalog, camera, condition, args.seed, i, source=args.source)
        flux = np.arange(len(bf.obs.x), 0, -1, dtype=float)  # brightest first already
        frames.append(FrameInput(f"frame_{i}", Centroids(bf.obs.x, bf.obs.y, flux)))
    print(f"simulated: {args.frames} frames from {args.source}, true 20 deg, k1 {args.k1} "
          f"(noise {args.noise_px} px for centroids), seed {args.seed}")
    for off in (0.04, -0.04):
        nominal = Camera.from_fov(1024, 1024, 20.0 * (1.0 + off))
        t0 = time.perf_counter()
        cal = calibrate(frames, nominal, catalog, terms=1)
        _print(cal, nominal, time.perf_counter() - t0, lens)


def _real(args) -> None:
    paths = sorted(REAL_SKY.glob("*.tiff"))
    if not paths:
        print(f"real: no frames in {REAL_SKY}")
        return
    frames = [read_input(p) for p in paths]
    print(f"real: {len(frames)} frames of {REAL_SKY} (true {REAL_FOV} deg), Hipparcos at "
          "epoch 2019.6")
    for fov in (11.0, REAL_FOV, 12.0):
        nominal = Camera.from_fov(1024, 768, fov)
        catalog = load_sky(resolve_sky(SkySpec(kind="hipparcos", epoch=2019.6), nominal),
                           nominal)
        t0 = time.perf_counter()
        cal = calibrate(frames, nominal, catalog, terms=1)
        _print(cal, nominal, time.perf_counter() - t0, None)


def _print(cal, nominal: Camera, seconds: float, truth: Camera | None) -> None:
    if cal is None:
        print(f"  nominal {nominal.fov_deg:.3f} deg: nothing solved ({seconds:.1f} s)")
        return
    cam = cal.camera
    k1 = cam.distortion.k1 if cam.distortion else 0.0
    line = (f"  nominal {nominal.fov_deg:7.3f} deg -> fov {cam.fov_deg:8.4f} deg, "
            f"k1 {k1:+.4f}, cx {cam.cx:7.2f}, cy {cam.cy:7.2f}; RMS {cal.rms_before_px:.3f} "
            f"-> {cal.rms_after_px:.3f} px over {cal.n_stars} stars ({cal.n_rejected} cut) "
            f"in {len(cal.solved)} frames, {seconds:.1f} s")
    if truth is not None:
        line += (f"; fov error {cam.fov_deg - truth.fov_deg:+.4f} deg, k1 error "
                 f"{(k1 - truth.distortion.k1) / abs(truth.distortion.k1):+.1%}")
    else:
        line += f"; fov error {cam.fov_deg - REAL_FOV:+.4f} deg"
    print(line, flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=8)
    parser.add_argument("--k1", type=float, default=-0.3)
    parser.add_argument("--noise-px", type=float, default=0.3)
    parser.add_argument("--source", choices=("centroids", "images"), default="centroids")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--no-real", action="store_true")
    args = parser.parse_args()
    _simulated(args)
    if not args.no_real:
        _real(args)


if __name__ == "__main__":
    main()
