"""Print solved rate, wrong count and identify time of the ``radial`` matcher.

Settings: ``hip20`` (Hipparcos Hp <= 6.5, 20 deg FOV, 1024 x 1024: the issue's benchmark)
and ``paper`` (the radial-features paper's camera: 4 x 4 deg, 4096 x 4096, 9 um pixels,
Hipparcos at ``--mag``).
Frames: random attitudes, 0.3 px noise on the true centroids, 3 false stars, 10% missing.

    .venv/bin/python scripts/bench/bench_radial.py --frames 200 --setting hip20
    .venv/bin/python scripts/bench/bench_radial.py --frames 100 --setting paper --mag 7.5
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tests"))

from synth import synthetic_frame  # noqa: E402

from startrack.attitude import angle_between_deg, random_attitudes  # noqa: E402
from startrack.camera import Camera  # noqa: E402
from startrack.database import StarDatabase  # noqa: E402
from startrack.matchers import get_matcher  # noqa: E402
from startrack.sky import SkySpec, load_sky  # noqa: E402
from startrack.solver import identify  # noqa: E402


def paper_camera() -> Camera:
    """4096 x 4096 pixels of 9 um; the focal length that makes the FOV 4 deg."""
    f_mm = (4096 * 9e-3 / 2.0) / math.tan(math.radians(2.0))
    return Camera.from_optics(4096, 4096, f_mm, 9.0)


def judge(frame, sol, catalog, camera: Camera, radius_px: float = 1.5) -> str:
    """"right", "wrong" or "unresolved". Unresolved: right but for identities swapped
    between catalog stars closer than ``radius_px`` in the image (doubles that no centroid
    separates), or a false star lying on a catalog star that was dropped. A wrong attitude
    (> 60 arcsec) or any other mismatch is wrong."""
    if angle_between_deg(sol.rotation, frame.rotation) * 3600.0 > 60.0:
        return "wrong"
    truth = frame.truth_rows[sol.obs_index]
    bad = truth != sol.cat_index
    if not bad.any():
        return "right"
    inv = frame.rotation.inv()
    gx, gy, _ = camera.vector_to_pixel(inv.apply(catalog.vectors[sol.cat_index[bad]]))
    tb = truth[bad]
    tx, ty, _ = camera.vector_to_pixel(inv.apply(catalog.vectors[np.maximum(tb, 0)]))
    ox, oy = frame.obs.x[sol.obs_index[bad]], frame.obs.y[sol.obs_index[bad]]
    sep = np.where(tb >= 0, np.hypot(gx - tx, gy - ty), np.hypot(gx - ox, gy - oy))
    return "wrong" if np.any(sep > radius_px) else "unresolved"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=200)
    ap.add_argument("--setting", choices=("hip20", "paper"), default="hip20")
    ap.add_argument("--mag", type=float, default=None, help="Hipparcos Hp limit")
    ap.add_argument("--noise", type=float, default=0.3)
    ap.add_argument("--false-stars", type=int, default=3)
    ap.add_argument("--missing", type=float, default=0.1)
    ap.add_argument("--seed", type=int, default=2024)
    ap.add_argument("--param", action="append", default=[],
                    help="matcher parameter NAME=VALUE (repeatable)")
    args = ap.parse_args()
    if args.setting == "hip20":
        camera, mag = Camera.from_fov(1024, 1024, 20.0), args.mag or 6.5
    else:
        camera, mag = paper_camera(), args.mag or 7.5
    catalog = load_sky(SkySpec(kind="hipparcos", mag_limit=mag))
    params = {k: float(v) if "." in v else int(v)
              for k, v in (p.split("=", 1) for p in args.param)}
    db = StarDatabase(catalog, camera)
    matcher = get_matcher("radial")(db, **params)
    t0 = time.perf_counter()
    matcher.prepare()
    build = time.perf_counter() - t0
    rng = np.random.default_rng(args.seed)
    rotations = random_attitudes(args.frames, rng)
    solved = wrong = unresolved = 0
    ms, n_obs, shortlist = [], [], []
    for k in range(args.frames):
        frame = synthetic_frame(catalog, camera, rotations[k], rng, noise_px=args.noise,
                                false_stars=args.false_stars, missing=args.missing)
        sol = identify(frame.obs, matcher)
        ms.append(sol.identify_ms)
        n_obs.append(len(frame.obs))
        shortlist.append(sol.diagnostics.extra.get("mean_shortlist", 0.0))
        if sol.solved:
            verdict = judge(frame, sol, catalog, camera)
            solved += verdict != "wrong"
            wrong += verdict == "wrong"
            unresolved += verdict == "unresolved"
    print(f"setting={args.setting} Hp<={mag} catalog={len(catalog)} stars "
          f"R={math.degrees(matcher.radius_rad):.3f} deg dr={matcher.ring_width_rad * 206265:.1f}"
          f" arcsec rings={matcher.table.n_rings} table build/load {build:.2f} s")
    print(f"frames={args.frames} observed stars/frame median={np.median(n_obs):.0f} "
          f"min={min(n_obs)} mean shortlist={np.mean(shortlist):.2f}")
    print(f"solved={solved}/{args.frames} ({100.0 * solved / args.frames:.1f}%) wrong={wrong} "
          f"(of which {unresolved} right but for unresolvable doubles) "
          f"median identify={np.median(ms):.2f} ms p95={np.percentile(ms, 95):.2f} ms")


if __name__ == "__main__":
    main()
