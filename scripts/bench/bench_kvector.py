"""Time k-vector range queries against binary search on the Hipparcos pair table.

Pairs of the Hipparcos catalog (Hp <= 6.5) closer than the diagonal of a 20 deg,
1024 x 1024 field; query windows as wide as the angle method's at 0.3 px centroid noise.
Prints ns per query for ``KVector.range``, for one ``np.searchsorted`` range per query
(``binary_search_range``), and for the whole batch in one vectorised ``np.searchsorted``.

Usage: .venv/bin/python scripts/bench/bench_kvector.py [--queries N] [--repeats R] [--noise-px S]
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np


def _best_ns_per_query(fn, n_queries: int, repeats: int) -> float:
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter_ns()
        fn()
        best = min(best, time.perf_counter_ns() - t0)
    return best / n_queries


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--queries", type=int, default=20000)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--noise-px", type=float, default=0.3)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()

    from startrack.camera import Camera
    from startrack.database import StarDatabase, binary_search_range
    from startrack.sky import SkySpec, load_sky

    catalog = load_sky(SkySpec(kind="hipparcos", mag_limit=6.5))
    camera = Camera.from_fov(1024, 1024, 20.0)
    table = StarDatabase(catalog, camera).pairs
    values, kv = table.angle, table.kvector
    half = 4.0 * math.sqrt(2.0) * args.noise_px / camera.f_px

    rng = np.random.default_rng(args.seed)
    centre = rng.choice(values, args.queries)  # query where the pairs are, like a matcher
    lows, highs = (centre - half).tolist(), (centre + half).tolist()
    n = args.queries

    def run_kvector():
        for lo, hi in zip(lows, highs, strict=True):
            kv.range(lo, hi)

    def run_binary():
        for lo, hi in zip(lows, highs, strict=True):
            binary_search_range(values, lo, hi)

    lo_arr, hi_arr = np.array(lows), np.array(highs)

    def run_batched():
        np.searchsorted(values, lo_arr, side="left")
        np.searchsorted(values, hi_arr, side="right")

    checked = [(kv.range(lo, hi), binary_search_range(values, lo, hi))
               for lo, hi in zip(lows[:2000], highs[:2000], strict=True)]
    same = all(a == b for a, b in checked)
    sizes = [stop - start for (start, stop), _ in checked]
    t_kv = _best_ns_per_query(run_kvector, n, args.repeats)
    t_bs = _best_ns_per_query(run_binary, n, args.repeats)
    t_batch = _best_ns_per_query(run_batched, n, args.repeats)

    print(f"pair table: {len(values):,} pairs, window +/- {math.degrees(half) * 3600:.1f} arcsec, "
          f"median answer {int(np.median(sizes)):,} pairs; {n:,} queries, best of {args.repeats}")
    print(f"answers identical on 2000 checked queries: {same}")
    print(f"k-vector (KVector.range, per query)         {t_kv:9.0f} ns/query")
    print(f"binary search (np.searchsorted, per query)  {t_bs:9.0f} ns/query")
    print(f"binary search (np.searchsorted, batched)    {t_batch:9.0f} ns/query")
    print(f"ratio k-vector / per-query binary search    {t_kv / t_bs:9.2f}")


if __name__ == "__main__":
    main()
