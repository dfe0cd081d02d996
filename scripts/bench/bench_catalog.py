"""Print how long the skies take to build: Hipparcos cold/warm cache, random sky, and cut counts.

Usage: .venv/bin/python scripts/bench/bench_catalog.py [--repeats N]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time

import numpy as np


def _best_of(fn, repeats: int) -> tuple[float, object]:
    best, result = float("inf"), None
    for _ in range(repeats):
        t0 = time.perf_counter()
        result = fn()
        best = min(best, time.perf_counter() - t0)
    return best, result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()

    from startrack.sky import SkySpec, catalog_file, load_hipparcos, load_sky, random_sky

    path = catalog_file()
    print(f"catalog: {path} ({path.stat().st_size / 1e6:.1f} MB)")
    with tempfile.TemporaryDirectory(prefix="startrack-bench-") as tmp:
        os.environ["STARTRACK_CACHE_DIR"] = tmp
        cold = []
        for _ in range(args.repeats):
            for entry in os.listdir(tmp):  # empty cache: every run parses the text
                os.remove(os.path.join(tmp, entry))
            t0 = time.perf_counter()
            load_hipparcos()
            cold.append(time.perf_counter() - t0)
        warm, hip = _best_of(load_hipparcos, args.repeats)
        warm_epoch, _ = _best_of(lambda: load_hipparcos(epoch=2019.6), args.repeats)
        spec = SkySpec(kind="hipparcos", mag_limit=6.5, epoch=2019.6, min_separation_deg=0.05)
        sky_time, sky = _best_of(lambda: load_sky(spec), args.repeats)
        cache_mb = sum(os.path.getsize(os.path.join(tmp, f)) for f in os.listdir(tmp)) / 1e6

    print(f"hipparcos stars: {len(hip)}  cache size: {cache_mb:.1f} MB")
    print(f"hipparcos load, cold cache (parse + write): best {min(cold) * 1e3:.0f} ms, "
          f"worst {max(cold) * 1e3:.0f} ms over {args.repeats}")
    print(f"hipparcos load, warm cache: {warm * 1e3:.1f} ms")
    print(f"hipparcos load, warm cache, epoch 2019.6: {warm_epoch * 1e3:.1f} ms")
    print(f"load_sky(hipparcos, Hp<=6.5, 2019.6, merge 0.05 deg): {sky_time * 1e3:.1f} ms, "
          f"{len(sky)} stars")
    for n in (2000, 20000, 100000):
        t, _ = _best_of(lambda n=n: random_sky(n_stars=n, seed=0), args.repeats)
        print(f"random sky, {n} stars: {t * 1e3:.1f} ms")
    for m in (6.0, 6.5, 7.0, 8.0):
        print(f"stars with Hp <= {m}: {int(np.sum(hip.mag <= m))}")


if __name__ == "__main__":
    main()
