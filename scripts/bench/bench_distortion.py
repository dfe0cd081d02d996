"""Lens distortion bench: frames through a Brown-Conrady k1 lens, solved with and without
the model in the camera file.

The camera is the hipparcos20 preset (20 deg, 1024 x 1024, Hipparcos Hp <= 6.5); k1 = -0.3
moves the image corners by about 14 px. For each k1 the same seeded frames (the bench's
deterministic frames, startrack.bench._frames) are solved twice: with the camera file that
carries the distortion (written to JSON and read back with startrack.camera._file, as a
user would give it) and with the pinhole camera file alone. A frame is correct when the
boresight is within 60 arcsec and no reported identity is wrong (startrack.bench._metrics);
``wrong`` counts solved frames that are not correct, ``bad_ids`` those with a wrong
identity among them; the boresight error columns cover every solved frame.

    .venv/bin/python scripts/bench/bench_distortion.py --frames 300 --k1 -0.02,-0.05,-0.1,-0.3
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np

from startrack.bench import Condition, make_frame, score_frame, true_camera
from startrack.camera import Camera, load_camera
from startrack.sky import SkySpec, load_sky
from startrack.solver import Identifier


def _camera_file(camera: Camera, folder: Path, name: str) -> Camera:
    path = folder / f"{name}.json"
    path.write_text(json.dumps(camera.to_dict()))
    return load_camera(path)


def _run(catalog, camera, told: Camera, k1: float, args, cache: dict) -> dict:
    """Solve ``args.frames`` frames through a k1 lens with the matcher told ``told``."""
    if told not in cache:
        cache[told] = Identifier(told, catalog, args.method)
    ident = cache[told]
    condition = Condition(noise_px=args.noise_px, distortion_k1=k1)  # frames through k1
    scores, t0 = [], time.perf_counter()
    for i in range(args.frames):
        frame = make_frame(catalog, camera, condition, args.seed, i, source=args.source)
        obs = type(frame.obs).from_pixels(frame.obs.x, frame.obs.y, told,
                                          frame.obs.sigma_rad * frame.obs.camera.f_px)
        scores.append(score_frame(ident.identify(obs), frame.truth_rows, frame.rotation,
                                  frame.n_in_view))
    err = np.array([s.boresight_error_arcsec for s in scores if s.solved])
    return {"solved": np.mean([s.solved for s in scores]),
            "correct": np.mean([s.correct for s in scores]),
            "wrong": int(sum(s.wrong for s in scores)),
            "wrong_ids": int(sum(s.n_id_wrong > 0 for s in scores)),
            "recall": np.mean([s.n_id_correct / max(s.n_real_observed, 1) for s in scores]),
            "err_med": float(np.median(err)) if len(err) else float("nan"),
            "err_p95": float(np.percentile(err, 95)) if len(err) else float("nan"),
            "seconds": time.perf_counter() - t0}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=300)
    parser.add_argument("--k1", default="-0.02,-0.05,-0.1,-0.3")
    parser.add_argument("--noise-px", type=float, default=0.3)
    parser.add_argument("--source", choices=("centroids", "images"), default="centroids")
    parser.add_argument("--method", default="pyramid")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--without", action=argparse.BooleanOptionalAction, default=True,
                        help="also solve without the model (slow where most fail)")
    args = parser.parse_args()
    camera = Camera.from_fov(1024, 1024, 20.0)
    catalog = load_sky(SkySpec(kind="hipparcos", mag_limit=6.5), camera)
    print(f"{args.frames} frames per row, {args.method}, {args.noise_px} px noise, "
          f"from {args.source}, seed {args.seed}; 20 deg 1024^2, Hipparcos Hp <= 6.5")
    print(f"{'k1':>6} {'corner px':>9} {'model':>8} {'solved':>7} {'correct':>8} "
          f"{'wrong':>5} {'bad_ids':>7} {'recall':>6} {'bore_med_as':>11} {'bore_p95_as':>11} "
          f"{'s':>6}")
    cache: dict = {}
    with tempfile.TemporaryDirectory() as tmp:
        pinhole = _camera_file(camera, Path(tmp), "pinhole")
        for k1 in (float(v) for v in args.k1.split(",")):
            lens = true_camera(camera, Condition(distortion_k1=k1))
            modelled = _camera_file(lens, Path(tmp), f"k1_{k1}")
            assert modelled.distortion == lens.distortion
            corner = np.array([[0.0, 0.0]])
            shift = np.hypot(*(np.array(lens.pinhole.vector_to_pixel(
                lens.pixel_to_vector(corner[:, 0], corner[:, 1]))[:2]) - corner.T))
            rows = [("with", modelled)] + ([("without", pinhole)] if args.without else [])
            for label, told in rows:
                r = _run(catalog, camera, told, k1, args, cache)
                print(f"{k1:>6g} {float(shift[0]):>9.1f} {label:>8} {r['solved']:>7.1%} "
                      f"{r['correct']:>8.1%} {r['wrong']:>5d} {r['wrong_ids']:>7d} "
                      f"{r['recall']:>6.3f} {r['err_med']:>11.1f} {r['err_p95']:>11.1f} "
                      f"{r['seconds']:>6.1f}",
                      flush=True)


if __name__ == "__main__":
    main()
