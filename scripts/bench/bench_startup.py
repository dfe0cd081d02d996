"""Start-up cost as a user meets it: the command line's (``--cli``), the first and the
second ``startrack identify`` of a real frame after install (``--frame``), and one
identify in a first and a second process (the default).

``--cli N`` times ``startrack --version`` and ``startrack identify --help``, N runs each, as
a user starts them (a new interpreter per run), and prints the median and range:

    .venv/bin/python scripts/bench/bench_startup.py --cli 20

``--frame IMAGE --fov DEG`` runs ``startrack identify IMAGE --fov DEG`` twice on an empty
database cache (a fresh install: the first run builds the catalog's tables into the cache,
the second loads them) and prints both wall times and their ratio:

    .venv/bin/python scripts/bench/bench_startup.py \
        --frame ../shared/real-sky/2019-07-29T204726_Alt40_Azi45_Try1.tiff --fov 11.42

By default both processes share an empty database cache; each prints its import time,
its database load and its first and second identify of one Hipparcos frame (20 deg,
0.3 px). The kernels are compiled at install, so nothing is compiled in either.

    .venv/bin/python scripts/bench/bench_startup.py --method pyramid
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

CHILD = """
import json, sys, time
t0 = time.perf_counter()
import numpy as np
from startrack.camera._model import Camera
from startrack.database import StarDatabase
from startrack.solver._lost_in_space import identify
from startrack.matchers import MatcherConfig, get_matcher
from startrack.camera import stars_in_view
from startrack.sky import SkySpec, load_sky
from startrack.attitude import random_attitudes
from startrack.match_records import Observation
t1 = time.perf_counter()
camera = Camera.from_fov(1024, 1024, 20.0)
catalog = load_sky(SkySpec(kind="hipparcos", mag_limit=6.5), camera)
matcher = get_matcher(sys.argv[1])(StarDatabase(catalog, camera), MatcherConfig())
matcher.prepare()
t2 = time.perf_counter()
rng = np.random.default_rng(0)
_, x, y = stars_in_view(catalog, camera, random_attitudes(1, rng)[0])
obs = Observation.from_pixels(x + rng.normal(0, 0.3, len(x)), y + rng.normal(0, 0.3, len(y)),
                              camera, 0.3)
first = identify(obs, matcher)
t3 = time.perf_counter()
second = identify(obs, matcher)
print(json.dumps({"import_s": t1 - t0, "prepare_s": t2 - t1, "first_ms": (t3 - t2) * 1e3,
                  "second_ms": second.identify_ms, "solved": bool(first.solved)}))
"""


def time_commands(runs: int) -> None:
    """Print the median wall time of each quick command over ``runs`` new processes."""
    import statistics

    for args in (["--version"], ["identify", "--help"]):
        seconds = []
        for _ in range(runs):
            t0 = time.perf_counter()
            subprocess.run([sys.executable, "-m", "startrack", *args], check=True,
                           stdout=subprocess.DEVNULL)
            seconds.append(time.perf_counter() - t0)
        print(f"startrack {' '.join(args):<16} median {statistics.median(seconds):.3f} s "
              f"(min {min(seconds):.3f}, max {max(seconds):.3f}; {runs} runs, load "
              f"{os.getloadavg()[0]:.1f})")


def first_and_second(frame: str, fov: float) -> int:
    """``startrack identify FRAME --fov FOV`` twice on an empty database cache."""
    env = dict(os.environ, STARTRACK_CACHE_DIR=tempfile.mkdtemp(prefix="startrack-db-"))
    seconds, setup = [], []
    for _ in range(2):
        t0 = time.perf_counter()
        out = subprocess.run([sys.executable, "-m", "startrack", "identify", frame, "--fov",
                              str(fov), "--format", "json"], env=env, capture_output=True,
                             text=True)
        seconds.append(time.perf_counter() - t0)
        record = json.loads(out.stdout) if out.stdout.strip() else {}
        setup.append(record.get("timing_ms", {}).get("setup", float("nan")))
        print(f"run {len(seconds)}: {seconds[-1]:.2f} s wall, exit {out.returncode}, "
              f"status {record.get('status')}, timing_ms.setup {setup[-1]:.0f}")
    print(f"first / second: {seconds[0] / seconds[1]:.2f} (load {os.getloadavg()[0]:.1f})")
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--method", default="pyramid")
    ap.add_argument("--cli", type=int, metavar="N", default=0,
                    help="time the quick commands over N runs instead")
    ap.add_argument("--frame", help="an image: its first and second identify instead")
    ap.add_argument("--fov", type=float, default=11.42, help="--fov of --frame's identify")
    args = ap.parse_args(argv)
    if args.cli:
        time_commands(args.cli)
        return 0
    if args.frame:
        return first_and_second(args.frame, args.fov)
    env = dict(os.environ, STARTRACK_CACHE_DIR=tempfile.mkdtemp(prefix="startrack-db-"))
    rows = []
    for label in ("first process", "second process"):
        t0 = time.perf_counter()
        out = subprocess.run([sys.executable, "-c", CHILD, args.method], env=env, check=True,
                             capture_output=True, text=True)
        row = json.loads(out.stdout.strip().splitlines()[-1])
        row["process_s"] = time.perf_counter() - t0
        rows.append((label, row))
    print(f"{args.method}, one Hipparcos frame, database cache empty before the first "
          f"process")
    print(f"{'':<15} {'process s':>9} {'import s':>8} {'prepare s':>9} "
          f"{'1st identify ms':>15} {'2nd identify ms':>15} solved")
    for label, r in rows:
        print(f"{label:<15} {r['process_s']:>9.2f} {r['import_s']:>8.2f} {r['prepare_s']:>9.2f} "
              f"{r['first_ms']:>15.1f} {r['second_ms']:>15.2f} {r['solved']}")
    print(f"first / second process time: {rows[0][1]['process_s'] / rows[1][1]['process_s']:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
