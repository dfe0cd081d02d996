"""Print the database's cold and warm start end to end and per stage, and its tables.

End to end (the issue's benchmark: Hipparcos, default magnitude limit, 20 deg FOV,
1024 x 1024): everything ``startrack identify`` does before its first match, each run
in a new process: imports, the compiled core's start (its first call), the catalog
(resolve_sky + load_sky), the pair and triangle tables and the default method's
``prepare``. Three cases, with empty temporary caches made for this run:

* first ever: no startrack cache (the first process after install);
* cold: no startrack cache again (the operating system's file cache now warm);
* warm: the cache filled, so the tables are read back and checked.

"total" is the sum of the stages after the imports (which are listed apart). Cold and
warm are the median of ``--repeat`` runs. Then, per sky, each table's in-process build
(cold) and load (warm) time, entries and sizes.

    .venv/bin/python scripts/bench/bench_database.py
    .venv/bin/python scripts/bench/bench_database.py --repeat 5 --skies none
    .venv/bin/python scripts/bench/bench_database.py --skies none --compare-with /tmp/old-checkout
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

T0 = time.perf_counter()

STAGES = ("imports", "core start", "catalog", "pairs", "triangles", "prepare")
FOV_DEG, SIZE = 20.0, 1024


def child() -> None:
    """One identify start-up in this process; prints its stage times as JSON."""
    import numpy as np

    from startrack._core.database import builds as kernels
    from startrack.camera import Camera
    from startrack.database import StarDatabase
    from startrack.defaults import DEFAULT_METHOD
    from startrack.matchers import get_matcher
    from startrack.sky import SkySpec, load_sky, resolve_sky

    times = {"imports": time.perf_counter() - T0}

    def stage(name, fn):
        t0 = time.perf_counter()
        out = fn()
        times[name] = time.perf_counter() - t0
        return out

    stage("core start", lambda: kernels.stable_argsort(np.zeros(1), 0.0, 1.0))
    camera = Camera.from_fov(SIZE, SIZE, FOV_DEG)
    spec = SkySpec(kind="hipparcos")
    catalog = stage("catalog", lambda: load_sky(resolve_sky(spec, camera), camera))
    db = StarDatabase(catalog, camera)
    stage("pairs", lambda: db.pairs)
    stage("triangles", lambda: db.triangles)
    stage("prepare", get_matcher(DEFAULT_METHOD)(db).prepare)
    print(json.dumps({"times": times, "stars": len(catalog), "method": DEFAULT_METHOD,
                      "mag": float(catalog.mag.max()), "pairs": len(db.pairs),
                      "triangles": len(db.triangles)}))


def run_child(cache: Path, code: str | None) -> dict:
    env = {**os.environ, "STARTRACK_CACHE_DIR": str(cache)}
    if code:
        env["PYTHONPATH"] = code
    out = subprocess.run([sys.executable, __file__, "--child"], env=env, check=True,
                         capture_output=True, text=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def end_to_end(repeat: int, root: Path, codes: dict[str, str | None]) -> None:
    """The three cases for each checkout in ``codes`` (label: its folder, None for this
    one), their runs interleaved so that a change of load hits all alike."""
    runs: dict[str, dict[str, list]] = {label: {} for label in codes}
    for case, caches in (("first ever", ["first"]), ("cold", [f"cold{k}" for k in range(repeat)]),
                         ("warm", ["cold0"] * repeat)):
        for name in caches:
            for k, (label, code) in enumerate(codes.items()):
                got = run_child(root / f"code{k}" / name, code)
                runs[label].setdefault(case, []).append(got)
    for label, by_case in runs.items():
        info = by_case["first ever"][0]
        print(f"{label}end to end, Hipparcos Hp <= {info['mag']:.1f} ({info['stars']} stars)"
              f", {FOV_DEG:g} deg, {SIZE}x{SIZE}, method {info['method']}: "
              f"{info['pairs']:,d} pairs, {info['triangles']:,d} triangles (seconds; cold "
              f"and warm: median of {repeat})")
        print(f"  {'case':<11}" + "".join(f"{s:>12}" for s in STAGES) + f"{'total':>10}")
        for case, results in by_case.items():
            med = {s: sorted(r["times"][s] for r in results)[len(results) // 2] for s in STAGES}
            totals = sorted(sum(r["times"][s] for s in STAGES[1:]) for r in results)
            print(f"  {case:<11}" + "".join(f"{med[s]:>12.3f}" for s in STAGES)
                  + f"{totals[len(totals) // 2]:>10.3f}")


def nbytes(table) -> int:
    """Bytes held by a table's arrays, its k-vector's included."""
    import numpy as np

    total = 0
    for f in dataclasses.fields(table):
        value = getattr(table, f.name)
        if isinstance(value, np.ndarray):
            total += value.nbytes
        elif dataclasses.is_dataclass(value):
            total += nbytes(value)
    return total


def entries(table) -> int:
    import numpy as np

    try:
        return len(table)
    except TypeError:
        return len(next(v for v in vars(table).values() if isinstance(v, np.ndarray)))


def _radial(db):
    """The radial table with the radial matcher's own parameters, if that matcher exists."""
    from startrack.errors import InputError
    from startrack.matchers import get_matcher

    try:
        cls = get_matcher("radial")
    except InputError:
        return None
    matcher = cls(db)
    matcher.prepare()
    return matcher.table


TABLES = {"pairs": lambda db: db.pairs, "triangles": lambda db: db.triangles,
          "radial": _radial}


def _sky(name: str):
    from startrack.sky import SkySpec, load_sky, random_sky

    if name == "hipparcos":
        return ("Hipparcos Hp <= 6.5, 20 deg, 1024x1024",
                load_sky(SkySpec(kind="hipparcos", mag_limit=6.5)), 20.0)
    return "random 2000 stars, 17.5 deg, 1024x1024", random_sky(2000, seed=0), 17.5


def _timed(get, db):
    t0 = time.perf_counter()
    table = get(db)
    return table, time.perf_counter() - t0


def bench_tables(name: str) -> None:
    """Each table built in an empty cache (pairs first, as every other needs them) and
    loaded by a second database on that cache, in this process."""
    import numpy as np

    from startrack.camera import Camera
    from startrack.database import StarDatabase

    cache = Path(tempfile.mkdtemp(prefix="startrack-dbbench-"))
    os.environ["STARTRACK_CACHE_DIR"] = str(cache)
    title, catalog, fov = _sky(name)
    camera = Camera.from_fov(1024, 1024, fov)
    cold, warm = StarDatabase(catalog, camera), StarDatabase(catalog, camera)
    print(f"{title}: {len(catalog)} stars, largest pair angle "
          f"{np.degrees(cold.max_angle_rad):.2f} deg")
    print(f"  {'table':<10} {'build s':>8} {'load s':>7} {'entries':>10} {'RAM MB':>7} "
          f"{'disk MB':>8}  notes")
    for table_name, get in TABLES.items():
        built, build_s = _timed(get, cold)
        loaded, load_s = _timed(get, warm)
        if built is None:
            print(f"  {table_name:<10} (no such table)")
            continue
        disk = sum(p.stat().st_size for p in cache.glob(f"{table_name}-*.npz"))
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
                    help="tables of: comma-separated hipparcos, random; or none")
    ap.add_argument("--repeat", type=int, default=3, help="cold and warm runs (median)")
    ap.add_argument("--no-end-to-end", action="store_true", help="only the tables")
    ap.add_argument("--compare-with", metavar="DIR", help="also time the startrack package "
                    "under DIR (an older checkout), runs interleaved with this one's")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        child()
        return
    root = Path(tempfile.mkdtemp(prefix="startrack-dbbench-"))
    codes: dict[str, str | None] = {"": None}
    if args.compare_with:  # another checkout's startrack, e.g. `git archive` of main
        codes = {f"[{args.compare_with}] ": args.compare_with, "[this checkout] ": None}
    if not args.no_end_to_end:
        end_to_end(max(1, args.repeat), root, codes)
    for name in args.skies.split(","):
        if name.strip() in ("hipparcos", "random"):
            bench_tables(name.strip())


if __name__ == "__main__":
    main()
