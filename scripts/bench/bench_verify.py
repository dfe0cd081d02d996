"""Time one hypothesis's verification (startrack.verify.verify: one compiled call) on
Hipparcos frames, accepted and refused hypotheses apart. Prints the medians in
microseconds.

    nice python scripts/bench/bench_verify.py [--frames 40]

Everything is built and called once before the timed calls (no compile, cache fill or
import is timed).
"""

from __future__ import annotations

import argparse
import sys
from functools import partial
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tests"))
from synth import synthetic_frame  # noqa: E402

from scripts.bench._timing import median_us  # noqa: E402
from startrack.attitude import random_attitudes  # noqa: E402
from startrack.camera import Camera  # noqa: E402
from startrack.database import StarDatabase  # noqa: E402
from startrack.match_records import Hypothesis  # noqa: E402
from startrack.sky import SkySpec, load_sky  # noqa: E402
from startrack.verify import (  # noqa: E402  # noqa: E402
    FrameVerifier,
    VerifyConfig,
    verify,
)

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
        compiled = median_us(partial(verify, hyp, obs, db, config, checker), REPEATS)
        call = median_us(partial(checker.check, obs_h, cat_h), REPEATS)
        rows[right].append((compiled, call))
    for right, label in ((True, "right hypothesis (accepted)"), (False, "random (refused)")):
        a = np.array(rows[right])
        print(f"{label}: {len(a)} hypotheses, median verify() {np.median(a[:, 0]):.1f} us, "
              f"its compiled call {np.median(a[:, 1]):.1f} us")


if __name__ == "__main__":
    main()
