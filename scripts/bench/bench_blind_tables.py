"""Quad pattern tables of the blind search: patterns, bytes and build time per level.

Builds (without the cache) every level that the FOV search over 1 to 40 deg may use, for
the whole Gaia catalog (what the blind search and a nominal FOV on the default sky load).
With ``--compare-with DIR`` the same is run for the startrack package in DIR (another
checkout), level by level in turn, so both see the same machine load.

    .venv/bin/python scripts/bench/bench_blind_tables.py [--levels 1,1.41,2] [--compare-with DIR]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path


def measure(level: float) -> dict:
    """Build one level of the Gaia catalog's table and say how big it is."""
    from startrack.database import _quads as Q
    from startrack.sky import SkySpec, load_sky

    catalog = load_sky(SkySpec(kind="gaia"), None)
    t0 = time.perf_counter()
    arrays = Q.build_level_arrays(catalog.vectors, level)
    seconds = time.perf_counter() - t0
    return {"level": level, "stars": min(len(catalog), Q.level_stars(level)),
            "patterns": len(arrays["keys"]),
            "mb": sum(a.nbytes for a in arrays.values()) / 1e6, "s": seconds}


def in_child(level: float, root: str | None) -> dict:
    env = dict(os.environ)
    if root:
        env["PYTHONPATH"] = root
    code = ("import json; from scripts.bench import bench_blind_tables as b; "
            f"print(json.dumps(b.measure({level})))")
    out = subprocess.run([sys.executable, "-c", code], env=env, check=True,
                         capture_output=True, text=True, cwd=root or None).stdout
    return json.loads(out.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--levels", default="1,1.414,2,2.828,4,5.657,8,11.31,16,22.63,32,45.25")
    ap.add_argument("--compare-with", metavar="DIR")
    args = ap.parse_args()
    levels = [float(v) for v in args.levels.split(",")]
    here = str(Path(__file__).resolve().parents[2])
    trees = {"this": here} | ({"other": os.path.abspath(args.compare_with)}
                              if args.compare_with else {})
    print("| level (deg) | " + " | ".join(f"{t} stars | {t} patterns | {t} MB | {t} build s"
                                         for t in trees) + " |")
    print("|---" * (1 + 4 * len(trees)) + "|")
    total = {t: [0.0, 0.0] for t in trees}
    for level in levels:
        cells = []
        for name, root in trees.items():
            r = in_child(level, root)
            total[name][0] += r["mb"]
            total[name][1] += r["s"]
            cells.append(f"{r['stars']} | {r['patterns']} | {r['mb']:.1f} | {r['s']:.1f}")
        print(f"| {level:g} | " + " | ".join(cells) + " |", flush=True)
    for name, (mb, s) in total.items():
        print(f"{name}: {mb:.0f} MB in all, {s:.0f} s to build")


if __name__ == "__main__":
    main()
