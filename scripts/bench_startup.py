"""Start-up cost: the command line's (``--cli``), and the compiled kernels' (one identify
in a first and a second process).

``--cli N`` times ``startrack --version`` and ``startrack identify --help``, N runs each, as
a user starts them (a new interpreter per run), and prints the median and range:

    .venv/bin/python scripts/bench_startup.py --cli 20

Both processes share a fresh numba cache folder (NUMBA_CACHE_DIR) and a database cache:
the first compiles the kernels and writes them to the cache, the second loads them. Each
prints its import time, its database load and its first and second identify of one
Hipparcos frame (20 deg, 0.3 px); this script prints them side by side.

    .venv/bin/python scripts/bench_startup.py --method pyramid
    PYTHONPATH=. /work/peers-venv/bin/python scripts/bench_startup.py --method pyramid
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
from startrack.simulate._scene import stars_in_view
from startrack.sky import SkySpec, load_sky
from startrack.attitude import random_attitudes
from startrack.types import Observation
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


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--method", default="pyramid")
    ap.add_argument("--cli", type=int, metavar="N", default=0,
                    help="time the quick commands over N runs instead")
    args = ap.parse_args(argv)
    if args.cli:
        time_commands(args.cli)
        return 0
    env = dict(os.environ, NUMBA_CACHE_DIR=tempfile.mkdtemp(prefix="startrack-numba-"))
    env.setdefault("STARTRACK_CACHE_DIR", tempfile.mkdtemp(prefix="startrack-db-"))
    subprocess.run([sys.executable, "-c", CHILD, args.method], env=env, check=True,
                   capture_output=True)  # builds the database tables, compiles
    env["NUMBA_CACHE_DIR"] = tempfile.mkdtemp(prefix="startrack-numba-")
    rows = []
    for label in ("first process", "second process"):
        t0 = time.perf_counter()
        out = subprocess.run([sys.executable, "-c", CHILD, args.method], env=env, check=True,
                             capture_output=True, text=True)
        row = json.loads(out.stdout.strip().splitlines()[-1])
        row["process_s"] = time.perf_counter() - t0
        rows.append((label, row))
    print(f"{args.method}, one Hipparcos frame, database tables already cached; numba "
          f"cache empty before the first process")
    print(f"{'':<15} {'process s':>9} {'import s':>8} {'prepare s':>9} "
          f"{'1st identify ms':>15} {'2nd identify ms':>15} solved")
    for label, r in rows:
        print(f"{label:<15} {r['process_s']:>9.2f} {r['import_s']:>8.2f} {r['prepare_s']:>9.2f} "
              f"{r['first_ms']:>15.1f} {r['second_ms']:>15.2f} {r['solved']}")
    print(f"first / second process time: {rows[0][1]['process_s'] / rows[1][1]['process_s']:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
