"""Time one hypothesis's verification (startrack.verify.verify: one compiled call) on
Hipparcos frames, accepted and refused hypotheses apart; and, while they exist, the numba
check kernels it replaced on the same hypotheses. Prints the medians in microseconds.

    nice python scripts/bench_verify.py [--frames 40]

Everything is built and called once before the timed calls (no compile, cache fill or
import is timed).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from functools import partial
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from synth import synthetic_frame  # noqa: E402

from startrack.attitude import random_attitudes  # noqa: E402
from startrack.camera import Camera  # noqa: E402
from startrack.database import StarDatabase  # noqa: E402
from startrack.sky import SkySpec, load_sky  # noqa: E402
from startrack.types import Hypothesis  # noqa: E402
from startrack.verify._frame import (  # noqa: E402
    CAPTURE,
    CONE_LOOKUP_MARGIN,
    MAX_REFINEMENTS,
    FrameVerifier,
    cone_radius,
)
from startrack.verify._labelling import kernel_params  # noqa: E402
from startrack.verify._verification import VerifyConfig, verify  # noqa: E402

REPEATS = 20


def _cases(db, frames, seed):
    rng = np.random.default_rng(seed)
    for rot in random_attitudes(frames, rng):
        frame = synthetic_frame(db.catalog, db.camera, rot, rng, noise_px=0.3, false_stars=2)
        real = np.flatnonzero(frame.truth_rows >= 0)
        if len(real) >= 8:
            yield frame.obs, Hypothesis(real[:3], frame.truth_rows[real[:3]]), True
            wrong = rng.choice(len(db.vectors), 3, replace=False)
            yield frame.obs, Hypothesis(real[:3], wrong), False


def _median_us(call) -> float:
    call()  # not timed: a first call
    times = []
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        call()
        times.append(time.perf_counter() - t0)
    return float(np.median(times)) * 1e6


def _numba_call(obs, db, config, hyp):
    from startrack.matching import check_kernels  # the numba original, while it exists

    radius = config.radius_px(obs)
    cone = cone_radius(obs.camera)
    params = check_kernels.pack_params(
        radius, math.cos(radius / obs.camera.f_px), cone * CONE_LOOKUP_MARGIN,
        math.cos(0.01 * cone), CAPTURE, MAX_REFINEMENTS, config.min_confirmed,
        config.max_false_probability, kernel_params(obs, radius))
    args = [np.ascontiguousarray(a, dtype=np.float64) for a in (obs.vectors, obs.x, obs.y)]
    idx, flux = db.cone_index, obs.kernel_flux()
    obs_h, cat_h = (np.asarray(a, np.int64) for a in (hyp.obs_index, hyp.cat_index))
    geometry = obs.camera.geometry
    return lambda: check_kernels.check_cone(*args, flux, obs_h, cat_h, idx.vectors,
                                            db.catalog.mag, idx.order, idx.ra_sorted,
                                            idx.band_start, geometry, params)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=40)
    args = parser.parse_args()
    camera = Camera.from_fov(1024, 1024, 20.0)
    db = StarDatabase(load_sky(SkySpec(kind="hipparcos", mag_limit=6.5), camera), camera)
    config = VerifyConfig()
    rows = {True: [], False: []}
    for obs, hyp, right in _cases(db, args.frames, seed=1):
        checker = FrameVerifier(obs, db, config)
        obs_h, cat_h = (np.asarray(a, np.int64) for a in (hyp.obs_index, hyp.cat_index))
        compiled = _median_us(partial(verify, hyp, obs, db, config, checker))
        call = _median_us(partial(checker.check, obs_h, cat_h))
        try:
            numba = _median_us(_numba_call(obs, db, config, hyp))
        except ImportError:
            numba = float("nan")
        rows[right].append((compiled, call, numba))
    for right, label in ((True, "right hypothesis (accepted)"), (False, "random (refused)")):
        a = np.array(rows[right])
        print(f"{label}: {len(a)} hypotheses, median verify() {np.median(a[:, 0]):.1f} us, "
              f"its compiled call {np.median(a[:, 1]):.1f} us, "
              f"the numba check kernel {np.median(a[:, 2]):.1f} us")


if __name__ == "__main__":
    main()
