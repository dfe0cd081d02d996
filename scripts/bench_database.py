"""Print build (cold) and load (warm) times, entries and sizes of the database tables.

Skies: (a) Hipparcos Hp <= 6.5 at 20 deg FOV, 1024 x 1024 (the issue's benchmark) and
(b) the random 2000-star sky at 17.5 deg (the 2011 paper's setup). Cold: a fresh
database in an empty temporary cache, so the time covers building and writing the table;
warm: a second fresh database on the same cache, so it covers reading it back (and the
k-vector). Tables: pairs, triangles and, when the radial matcher exists, its radial table.

    .venv/bin/python scripts/bench_database.py
    .venv/bin/python scripts/bench_database.py --skies random
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import tempfile
import time
from pathlib import Path

import numpy as np

from startrack.camera import Camera
from startrack.database import StarDatabase
from startrack.errors import InputError
from startrack.matchers import get_matcher
from startrack.sky import SkySpec, load_sky, random_sky

SKIES = {
    "hipparcos": ("Hipparcos Hp <= 6.5, 20 deg, 1024x1024",
                  lambda: load_sky(SkySpec(kind="hipparcos", mag_limit=6.5)), 20.0),
    "random": ("random 2000 stars, 17.5 deg, 1024x1024", lambda: random_sky(2000, seed=0),
               17.5),
}


def _radial(db: StarDatabase):
    """The radial table with the radial matcher's own parameters, if that matcher exists."""
    try:
        cls = get_matcher("radial")
    except InputError:
        return None
    matcher = cls(db)
    matcher.prepare()
    return matcher.table


TABLES = {"pairs": lambda db: db.pairs, "triangles": lambda db: db.triangles,
          "radial": _radial}


def nbytes(table) -> int:
    """Bytes held by a table's arrays, its k-vector's included."""
    total = 0
    for f in dataclasses.fields(table):
        value = getattr(table, f.name)
        if isinstance(value, np.ndarray):
            total += value.nbytes
        elif dataclasses.is_dataclass(value):
            total += nbytes(value)
    return total


def entries(table) -> int:
    try:
        return len(table)
    except TypeError:
        return len(next(v for v in vars(table).values() if isinstance(v, np.ndarray)))


def bench_sky(name: str) -> None:
    title, load, fov = SKIES[name]
    catalog = load()
    camera = Camera.from_fov(1024, 1024, fov)
    cache = Path(tempfile.mkdtemp(prefix="startrack-dbbench-"))
    os.environ["STARTRACK_CACHE_DIR"] = str(cache)
    print(f"{title}: {len(catalog)} stars, largest pair angle "
          f"{np.degrees(StarDatabase(catalog, camera).max_angle_rad):.2f} deg")
    print(f"  {'table':<10} {'build s':>8} {'load s':>7} {'entries':>10} {'RAM MB':>7} "
          f"{'disk MB':>8}  notes")
    cold, warm = StarDatabase(catalog, camera), StarDatabase(catalog, camera)
    _ = cold.pairs, warm.pairs  # other tables are built from the pairs: time them alone
    for table_name, get in TABLES.items():
        t0 = time.perf_counter()
        built = get(cold) if table_name != "pairs" else None
        build_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        loaded = get(warm) if table_name != "pairs" else None
        load_s = time.perf_counter() - t0
        if table_name == "pairs":
            # Pairs were touched above; time them on two more fresh databases.
            cache_pairs = Path(tempfile.mkdtemp(prefix="startrack-dbbench-"))
            os.environ["STARTRACK_CACHE_DIR"] = str(cache_pairs)
            t0 = time.perf_counter()
            built = StarDatabase(catalog, camera).pairs
            build_s = time.perf_counter() - t0
            t0 = time.perf_counter()
            loaded = StarDatabase(catalog, camera).pairs
            load_s = time.perf_counter() - t0
            os.environ["STARTRACK_CACHE_DIR"] = str(cache)
        if built is None:
            print(f"  {table_name:<10} (no such table)")
            continue
        disk = sum(p.stat().st_size for p in cache.glob(f"{table_name}-*.npz"))
        if table_name == "pairs":
            disk = sum(p.stat().st_size for p in cache_pairs.glob("pairs-*.npz"))
        note = ""
        if table_name == "triangles":
            cap = built.max_per_region
            note = (f"{len(built.pattern)} pattern stars, "
                    + ("no thinning" if cap is None else f"< {cap} brighter within fov/2"))
        assert entries(loaded) == entries(built)
        print(f"  {table_name:<10} {build_s:>8.2f} {load_s:>7.3f} {entries(built):>10,d} "
              f"{nbytes(built) / 1e6:>7.1f} {disk / 1e6:>8.1f}  {note}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--skies", default="hipparcos,random",
                    help="comma-separated: " + ", ".join(SKIES))
    args = ap.parse_args()
    for name in args.skies.split(","):
        bench_sky(name.strip())


if __name__ == "__main__":
    main()
