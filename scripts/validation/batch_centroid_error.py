"""A batch of frames from one camera whose star images differ in size (so in centroid
error, which an image's star areas set): per-frame time, setup and the process's memory.

    .venv/bin/python scripts/validation/batch_centroid_error.py --frames 12 --fov 12

The frames are the default sky's stars in view of seeded attitudes, each frame's star
areas larger than the last (a centroid error of its own each), solved in one
:class:`startrack.solver.Pipeline` with the FOV given (exact, and nominal at the default
tolerance). A pipeline that held an identifier per centroid error reloaded and warmed its
tables for every new value; one per camera, sky and method is told each input's error.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from scripts._cli import add_camera, add_frames, script_parser
from startrack.attitude import random_attitudes
from startrack.camera import Camera, stars_in_view
from startrack.centroids import Centroids
from startrack.defaults import DEFAULT_FOV_TOLERANCE
from startrack.io import resident_bytes
from startrack.solver import FrameInput, Options, Pipeline


def run_batch(camera: Camera, tolerance: float, frames: int, seed: int, noise_px: float):
    """(rows of (centroid error, solved, solve ms, setup ms), the pipeline)."""
    pipeline = Pipeline(Options(fov_deg=camera.fov_deg, size=(camera.width, camera.height),
                                fov_tolerance=tolerance))
    rng = np.random.default_rng(seed)
    catalog = pipeline.catalog(pipeline.setup_for(FrameInput(
        "sky", Centroids(np.zeros(3), np.zeros(3), np.ones(3))))[1], camera)
    rows = []
    for k, rotation in enumerate(random_attitudes(frames, rng)):
        _, x, y = stars_in_view(catalog, camera, rotation)
        x, y = x + rng.normal(0, noise_px, len(x)), y + rng.normal(0, noise_px, len(y))
        area = np.full(len(x), 30 + 12 * k, np.int64)  # each frame's star images larger
        frame = FrameInput(f"frame{k}", Centroids(x, y, np.arange(len(x), 0, -1.0),
                                                  area=area))
        t0 = time.perf_counter()
        result = pipeline.solve(frame)
        rows.append((result.sigma_px, result.solution.solved,
                     (time.perf_counter() - t0) * 1000.0, result.timing.setup))
    return rows, pipeline


def main(argv: list[str] | None = None) -> int:
    ap = script_parser(__doc__)
    add_frames(ap, 12, seed=0)
    add_camera(ap, noise_px=0.3, fov=12.0)
    args = ap.parse_args(argv)
    camera = Camera.from_fov(args.size, args.size, args.fov)
    for tolerance in (0.0, DEFAULT_FOV_TOLERANCE):
        rows, pipeline = run_batch(camera, tolerance, args.frames, args.seed, args.noise_px)
        later = rows[1:]  # the first frame loads the tables
        print(f"FOV {args.fov:g} deg, tolerance {tolerance:g}: {sum(r[1] for r in rows)}/"
              f"{len(rows)} solved, centroid errors {rows[0][0]:.3f}-{rows[-1][0]:.3f} px, "
              f"{len({round(r[0], 9) for r in rows})} distinct; after the first frame: "
              f"mean {np.mean([r[2] for r in later]):.2f} ms a frame, setup "
              f"{sum(r[3] for r in later):.1f} ms in all; identifiers held "
              f"{len(pipeline._identifiers)}; resident {resident_bytes() >> 20} MB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
