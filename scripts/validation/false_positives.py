"""No-false-positive check and the time of a "no": random centroids (no star pattern) must
never be "solved", and should be refused fast.

Each set has 4 to 60 centroids uniform over a 1024 x 1024 frame of 20 degrees, run
against the Hipparcos database (Hp <= 6.5) that ``startrack identify`` would use. Any
solution is a false positive; the count must be 0. Each method's median and p99 time per
set are printed, with tetra3rs beside (its solve call) when it is importable, and the
ratio of medians measured in this one run.

    .venv/bin/python scripts/validation/false_positives.py --sets 1000 --seed 0
    .venv/bin/python scripts/validation/false_positives.py --sets 1000 --methods all
    PYTHONPATH=. /work/peers-venv/bin/python scripts/validation/false_positives.py --sets 300 \
        --methods pyramid,angle,hybrid,tetra3rs
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from startrack.camera import Camera
from startrack.centroids import DEFAULT_SIGMA_PX
from startrack.database import StarDatabase
from startrack.defaults import DEFAULT_METHOD
from startrack.errors import InputError
from startrack.match_records import Observation
from startrack.matchers import MatcherConfig, available_methods, get_matcher
from startrack.sky import SkySpec, load_sky
from startrack.solver import identify
from startrack.verify import VerifyConfig


def random_sets(camera: Camera, n_sets: int, seed: int, lo: int, hi: int,
                sigma_px: float) -> list[Observation]:
    rng = np.random.default_rng(seed)
    sets = []
    for _ in range(n_sets):
        n = int(rng.integers(lo, hi + 1))
        sets.append(Observation.from_pixels(rng.uniform(-0.5, camera.width - 0.5, n),
                                            rng.uniform(-0.5, camera.height - 0.5, n),
                                            camera, sigma_px))
    return sets


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sets", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--methods", default=DEFAULT_METHOD,
                    help=f"comma-separated, or 'all' (default: {DEFAULT_METHOD})")
    ap.add_argument("--min-stars", type=int, default=4)
    ap.add_argument("--max-stars-per-set", type=int, default=60)
    ap.add_argument("--timeout-ms", type=float, default=None,
                    help="identify's wall-clock limit (default: none)")
    ap.add_argument("--sigma-px", type=float, default=DEFAULT_SIGMA_PX,
                    help="assumed centroid sigma (larger = wider windows = harder test)")
    ap.add_argument("--fov", type=float, default=20.0)
    ap.add_argument("--mag-limit", type=float, default=6.5)
    args = ap.parse_args(argv)

    methods = available_methods() if args.methods == "all" else [
        m.strip() for m in args.methods.split(",") if m.strip()]
    unknown = [m for m in methods if m not in available_methods()]
    if unknown:
        print(f"unknown method(s) {unknown}; available: {available_methods()}", file=sys.stderr)
        return 2
    camera = Camera.from_fov(1024, 1024, args.fov)
    catalog = load_sky(SkySpec(kind="hipparcos", mag_limit=args.mag_limit), camera)
    sets = random_sets(camera, args.sets, args.seed, args.min_stars, args.max_stars_per_set,
                       args.sigma_px)
    verify = VerifyConfig()
    print(f"{args.sets} random centroid sets ({args.min_stars}-{args.max_stars_per_set} stars, "
          f"seed {args.seed}), Hipparcos Hp <= {args.mag_limit} ({len(catalog)} stars), "
          f"{args.fov} deg FOV, sigma {args.sigma_px} px, match radius "
          f"{verify.radius_px(sets[0]):.2f} px")
    print(f"{'method':<10} {'solved':>8} {'hyps/set':>9} {'max hyps':>8} "
          f"{'median ms':>9} {'p99 ms':>8} {'max ms':>8} {'timeouts':>8} {'seconds':>8}")
    failures, medians = 0, {}
    for name in methods:
        try:
            matcher = get_matcher(name)(StarDatabase(catalog, camera), MatcherConfig())
            matcher.prepare()
        except InputError as exc:
            print(f"skipping {name}: {exc}", file=sys.stderr)
            continue
        identify(sets[0], matcher, verify)  # compiled kernels loaded before timing
        t0 = time.perf_counter()
        solved, hyps, times, timeouts = 0, [], [], 0
        for obs in sets:
            sol = identify(obs, matcher, verify, timeout_ms=args.timeout_ms)
            solved += sol.solved
            timeouts += sol.reason == "timeout"
            hyps.append(sol.diagnostics.hypotheses)
            times.append(sol.identify_ms if sol.diagnostics.method_ms is None
                         else sol.diagnostics.method_ms)
        failures += solved
        medians[name] = float(np.median(times))
        print(f"{name:<10} {solved:>8} {np.mean(hyps):>9.1f} {max(hyps):>8} "
              f"{np.median(times):>9.2f} {np.percentile(times, 99):>8.2f} "
              f"{max(times):>8.1f} {timeouts:>8} {time.perf_counter() - t0:>8.1f}")
    if "tetra3rs" in medians:
        for name, median in medians.items():
            if name != "tetra3rs":
                print(f"median 'no' time ratio {name} / tetra3rs: "
                      f"{median / medians['tetra3rs']:.2f}")
    print("PASS: no random set was solved" if failures == 0
          else f"FAIL: {failures} false solution(s)")
    return 0 if failures == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
