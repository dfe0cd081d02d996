"""tetra3 and tetra3rs on bench_blind.py's frames, given the same information as startrack:
a FOV estimate off by 0, 2, 5 or 10 % with a maximum error of 10 % (their database built
for that range), and no FOV (estimate None; database over ``NO_FOV_SPAN`` about the true
FOV, narrower than startrack's 1-40 deg search, which they take too long to build here).
Their own answers are scored (solved, boresight > 60 arcsec off = wrong, solve time).

    PYTHONPATH=. /work/peers-venv/bin/python scripts/bench_blind_peers.py [--fovs 11.4,20]
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from bench_blind import WRONG_ARCSEC, frames_for  # noqa: E402

from startrack.cache import cached_file  # noqa: E402
from startrack.matchers._peer import write_gaia_binary, write_hip_main  # noqa: E402
from startrack.matchers.tetra3 import attitude_from_tetra3, tetra3_centroids  # noqa: E402
from startrack.matchers.tetra3rs import attitude_from_tetra3rs, tetra3rs_centroids  # noqa: E402

TOLERANCE = 0.10
NO_FOV_SPAN = 2.0  # the peers' no-FOV database covers [fov / span, fov * span]


def tetra3_solver(catalog, lo: float, hi: float):
    import tetra3

    def build(path: Path) -> None:
        with tempfile.TemporaryDirectory(dir=path.parent) as tmp:
            star_file = Path(tmp) / "hip_main.dat"
            write_hip_main(catalog, star_file)
            t3 = tetra3.Tetra3(load_database=None)
            t3.generate_database(max_fov=hi, min_fov=lo, star_catalog=str(star_file),
                                 star_max_magnitude=float(catalog.mag.max()) + 1e-3,
                                 epoch_proper_motion=None)
            t3.save_database(path)

    params = {"catalog": catalog.fingerprint(), "lo": round(lo, 6), "hi": round(hi, 6)}
    return tetra3.Tetra3(load_database=cached_file("tetra3-range", params, ".npz", build))


def tetra3rs_solver(catalog, lo: float, hi: float):
    import tetra3rs

    def build(path: Path) -> None:
        star_file = path.with_name(path.name + "-catalog.bin")
        try:
            write_gaia_binary(catalog, star_file)
            db = tetra3rs.SolverDatabase.generate_from_gaia(
                str(star_file), max_fov_deg=hi, min_fov_deg=lo,
                star_max_magnitude=float(catalog.mag.max()) + 1e-3,
                epoch_proper_motion_year=None)
            db.save_to_file(str(path))
        finally:
            star_file.unlink(missing_ok=True)

    params = {"catalog": catalog.fingerprint(), "lo": round(lo, 6), "hi": round(hi, 6)}
    path = cached_file("tetra3rs-range", params, ".bin", build)
    return tetra3rs.SolverDatabase.load_from_file(str(path))


def solve(peer: str, solver, frame, camera, estimate: float | None, max_error: float | None):
    obs = frame.obs
    t0 = time.perf_counter()
    if peer == "tetra3":
        r = solver.solve_from_centroids(tetra3_centroids(obs), (camera.height, camera.width),
                                        fov_estimate=estimate, fov_max_error=max_error,
                                        distortion=None)
        ms = (time.perf_counter() - t0) * 1000.0
        if r.get("RA") is None:
            return False, None, ms
        rot = attitude_from_tetra3(r["RA"], r["Dec"], r["Roll"])
    else:
        r = solver.solve_from_centroids(tetra3rs_centroids(obs), fov_estimate_deg=estimate,
                                        fov_max_error_deg=max_error, image_width=camera.width,
                                        image_height=camera.height)
        ms = (time.perf_counter() - t0) * 1000.0
        if not r or r.parity_flip:
            return False, None, ms
        rot = attitude_from_tetra3rs(r.rotation_matrix_icrs_to_camera)
    b, t = rot.apply([0.0, 0.0, 1.0]), frame.rotation.apply([0.0, 0.0, 1.0])
    return True, math.degrees(math.acos(min(1.0, float(b @ t)))) * 3600.0, ms


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=8)
    ap.add_argument("--fovs", default="11.4,20")
    ap.add_argument("--errors", default="0,2,5,10")
    ap.add_argument("--seed", type=int, default=7)
    args = ap.parse_args()
    for fov in (float(v) for v in args.fovs.split(",")):
        camera, frames, catalog = frames_for(fov, args.frames, args.seed, with_catalog=True)
        errors = [float(e) for e in args.errors.split(",")]
        settings = [(f"{e:g}%", e) for e in errors] + [("no FOV", None)]
        for peer, make in (("tetra3", tetra3_solver), ("tetra3rs", tetra3rs_solver)):
            for label, err in settings:
                if err is None:
                    solver = make(catalog, fov / NO_FOV_SPAN, fov * NO_FOV_SPAN)
                else:
                    solver = make(catalog, fov * (1 - TOLERANCE), fov * (1 + TOLERANCE))
                solved = wrong = 0
                times = []
                for i, frame in enumerate(frames):
                    sign = 1.0 if i % 2 == 0 else -1.0
                    est = None if err is None else fov * (1 + sign * err / 100.0)
                    ok, off, ms = solve(peer, solver, frame, camera, est,
                                        None if err is None else TOLERANCE * est)
                    times.append(ms)
                    solved += ok
                    wrong += bool(ok and off > WRONG_ARCSEC)
                print(f"{peer:8s} fov {fov:5.1f}  given {label:7s}  solved {solved}/"
                      f"{len(frames)}  wrong {wrong}  median {np.median(times):7.0f} ms  "
                      f"max {np.max(times):7.0f} ms", flush=True)


if __name__ == "__main__":
    main()
