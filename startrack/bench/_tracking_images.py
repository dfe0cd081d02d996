"""The tracking bench on rendered frames: a sequence drawn by the sensor model and solved
through the whole pipeline, as ``identify --track`` and ``identify`` solve image files.

The centroid-list bench (:mod:`startrack.bench._tracking_bench`) times matching and verification
alone, with the exact camera. Here each frame is a rendered image (the bench's trajectory,
motion blur at its rate, dropouts and false stars), so its centroids come from the frame,
and the camera's field of view is taken as the user gives it: nominal (``identify``'s
default, ``fov_tolerance`` > 0: lost-in-space fits it on every frame, while a tracked
frame keeps the camera its sequence fitted) or exact (``fov_tolerance=0``). Runs are
interleaved within each frame, as in the centroid-list bench.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from startrack.api import Solver
from startrack.attitude import boresight_error_arcsec
from startrack.bench._tracking_bench import RATE_AXIS, TrackCondition, seeded_rotations
from startrack.camera import Camera
from startrack.defaults import DEFAULT_FOV_TOLERANCE
from startrack.simulate import SensorModel, observe, render_frame
from startrack.sky import Catalog, SkySpec

#: (field of view as given, fov_tolerance): the two ways a user can give the camera
FOV_CASES = (("nominal", DEFAULT_FOV_TOLERANCE), ("exact", 0.0))
#: an attitude further than this from the truth counts as wrong (as the centroid bench)
WRONG_ARCSEC = 60.0


def rendered_sequence(catalog: Catalog, camera: Camera, sensor: SensorModel,
                      cond: TrackCondition, count: int, fps: float, seed: int):
    """Yield (image, true rotation) for ``count`` frames of the bench's trajectory
    (:func:`startrack.bench._tracking_bench.make_sequence`'s, from the same seed), each frame
    blurred by the rate over the sensor's exposure."""
    rate = tuple(float(w) for w in RATE_AXIS * cond.rate_dps)
    rotations = seeded_rotations(cond, count, fps, seed)
    for k in range(count):
        rng = np.random.default_rng([seed, k, 2])
        scene = observe(catalog, camera, rotations[k], rng, missing=cond.missing,
                        false_stars=int(cond.false_stars))
        image = render_frame(scene, camera, sensor, rng, angular_rate_dps=rate)
        yield image, rotations[k]


def run_images(catalog: Catalog, spec: SkySpec, camera: Camera, sensor: SensorModel,
               cond: TrackCondition, count: int, fps: float, seed: int,
               method: str = "pyramid") -> pd.DataFrame:
    """One row per frame and run: ``fov`` (:data:`FOV_CASES`), ``run`` ("track" or
    "lost_in_space"), whether solved, the mode, the identify and centroid times (ms) and
    the boresight error (arcsec; NaN when not solved)."""
    solvers = {(fov, run): Solver(camera=camera, sky=spec.kind, mag_limit=spec.mag_limit,
                                  method=method, fov_tolerance=tol, track=run == "track")
               for fov, tol in FOV_CASES for run in ("track", "lost_in_space")}
    rows = []
    frames = rendered_sequence(catalog, camera, sensor, cond, count, fps, seed)
    for k, (image, truth) in enumerate(frames):
        for (fov, run), solver in solvers.items():
            result = solver.solve(image)
            timing = result.to_dict()["timing_ms"]  # as identify reports it
            err = (boresight_error_arcsec(result.frame.solution.rotation, truth)
                   if result.solved else float("nan"))
            rows.append({"frame": k, "fov": fov, "run": run, "solved": result.solved,
                         "mode": result.mode, "identify_ms": timing["identify"],
                         "centroid_ms": timing["centroid"], "error_arcsec": err})
    return pd.DataFrame(rows)


def summarise_images(df: pd.DataFrame) -> pd.DataFrame:
    """Per field-of-view case and run: frames, solved, tracked, wrong, the median identify
    and centroid times; and per case, lost-in-space's median identify time over
    tracking's."""
    out = []
    for (fov, run), g in df.groupby(["fov", "run"], sort=False):
        out.append({"fov": fov, "run": run, "frames": len(g), "solved": int(g["solved"].sum()),
                    "tracked": int((g["mode"] == "tracking").sum()),
                    "wrong": int((g["error_arcsec"] > WRONG_ARCSEC).sum()),
                    "identify_ms": float(g["identify_ms"].median()),
                    "centroid_ms": float(g["centroid_ms"].median())})
    table = pd.DataFrame(out)
    medians = table.set_index(["fov", "run"])["identify_ms"]
    table["lis_over_track"] = [medians[(fov, "lost_in_space")] / medians[(fov, "track")]
                               for fov in table["fov"]]
    return table

__all__ = ["FOV_CASES", "WRONG_ARCSEC", "rendered_sequence", "run_images", "summarise_images"]
