"""Why a frame of scripts/bench/bench_blind_cameras.py is not solved: per frame, where the true
pattern is lost in the quad search of :mod:`startrack.solver._fov_search`.

For each frame (of one camera, FOV told 4 % off or not at all) this prints the
detections' truth (rank of each catalog star in the brightness order), whether the
pipeline solved it, and per search window: the candidates, the true candidates among
them (every star real and named right), the best true candidate's rank and confirmation
count, and whether verification accepts it (:func:`startrack.solver._fov_search.verify_fitted`, its
confirmed count and false-match probability).

    .venv/bin/python scripts/bench/bench_blind_diagnose.py --fov 1 [--frames 0,3] [--blind]
"""

from __future__ import annotations

import argparse
import dataclasses
import math

import numpy as np
from scipy.spatial import cKDTree

from scripts.bench.bench_blind import _pipeline, solve_ours  # noqa: E402
from scripts.bench.bench_blind_cameras import CAMERAS, FOV_ERROR, camera_frames, score  # noqa: E402
from startrack.match_records import MatchDiagnostics, Observation  # noqa: E402
from startrack.sky import SkySpec  # noqa: E402
from startrack.solver import Options  # noqa: E402
from startrack.solver import _fov_search as F  # noqa: E402
from startrack.verify import verify  # noqa: E402


def solver_rows(frame, bench_catalog, solver_catalog) -> np.ndarray:
    """Each detection's row in the solver's catalog (-1: a false or uncatalogued star)."""
    truth = frame.truth_rows
    out = np.full(len(truth), -1, np.int64)
    real = truth >= 0
    if real.any():
        d, rows = cKDTree(solver_catalog.vectors).query(bench_catalog.vectors[truth[real]])
        out[real] = np.where(d < 1e-5, rows, -1)
    return out


def window_report(matcher, x, y, camera, lo, hi, db, config, sigma, rows) -> str:
    """One window's candidates against the truth ``rows`` (solver rows per detection)."""
    diag = MatchDiagnostics()
    cands = matcher.scaled(x, y, camera, lo, hi, diag, db)
    true = [k for k, sh in enumerate(cands)
            if np.array_equal(rows[sh.hypothesis.obs_index], sh.hypothesis.cat_index)]
    fov_lo, fov_hi = (math.degrees(2 * math.atan(camera.width / 2 / f)) for f in (hi, lo))
    head = f"  window {fov_lo:6.3f}-{fov_hi:6.3f} deg: {len(cands):5d} candidates"
    if not true:
        return head + ", no true one"
    k = true[0]
    sh = cands[k]
    guess = F._fitted_guess(sh, x, y, camera, sigma, db, config)
    obs = Observation.from_pixels(x, y, guess, sigma)
    check = verify(sh.hypothesis, obs, db, config)
    fitted = F.verify_fitted(sh.hypothesis, x, y, guess, sigma, db, config)
    ahead = sum(c.confirmed >= F.MIN_CONFIRMED for c in cands[:k])
    return (f"{head}, {len(true)} true; best true at rank {k} ({ahead} verifiable ahead), "
            f"stars {sh.hypothesis.obs_index.tolist()} confirmed {sh.confirmed}; verify: "
            f"accepted {check.accepted} confirmed {check.confirmed} "
            f"p {check.false_probability:.1e}; fitted {'ok' if fitted else 'rejected'}")


def diagnose(spec, cam, frames, bench_catalog, index: int, blind: bool) -> None:
    fov, width, height, _ = spec
    frame = frames[index]
    size = (width, height)
    if blind:
        options = Options(size=size)
    else:
        sign = 1.0 if index % 2 == 0 else -1.0
        options = Options(fov_deg=fov * (1.0 + sign * FOV_ERROR), size=size)
    pipe = _pipeline(options)
    result, ms = solve_ours(pipe, frame)
    solver = pipe.blind_solver(SkySpec(kind="gaia"))
    rows = solver_rows(frame, bench_catalog, solver.catalog)
    ranks = np.flatnonzero(rows >= 0)
    state = "missed" if result is None else (
        "WRONG" if score(result, frame, bench_catalog, cam) else "solved")
    print(f"frame {index} ({'no FOV' if blind else f'FOV {options.fov_deg:.3f}'}): {state} "
          f"in {ms:.0f} ms; {len(rows)} detections, catalog stars at ranks {ranks.tolist()}")
    if result is not None:
        return
    x, y = frame.obs.x, frame.obs.y
    if blind:
        camera = None
        base = dataclasses.replace(frame.obs.camera, distortion=None)
        spans = F.windows(*(F.f_of_fov(width, v) for v in sorted(F.BLIND_FOV_RANGE)[::-1]))
        spans = [w for w in spans if w[0] <= frame.obs.camera.f_px * 1.3
                 and w[1] >= frame.obs.camera.f_px / 1.3]
    else:
        from startrack.camera import Camera

        camera = base = Camera.from_fov(width, height, options.fov_deg)
        spans = F.windows(*F.focal_range(camera, options.fov_tolerance))
    for lo, hi in spans:
        db = solver.database_for(dataclasses.replace(base, f_px=math.sqrt(lo * hi)))
        print(window_report(solver.matcher, x, y, base, lo, hi, db, solver.config,
                            solver.sigma_px, rows))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fov", type=float, required=True)
    ap.add_argument("--frames", default=None, help="frame indices (default: all 10)")
    ap.add_argument("--n", type=int, default=10)
    ap.add_argument("--seed", type=int, default=11)
    ap.add_argument("--blind", action="store_true", help="no FOV told")
    args = ap.parse_args()
    spec = next(c for c in CAMERAS if c[0] == args.fov)
    camera, frames, catalog = camera_frames(spec, args.n, args.seed)
    picks = range(args.n) if args.frames is None else [int(v) for v in args.frames.split(",")]
    for i in picks:
        diagnose(spec, camera, frames, catalog, i, args.blind)


if __name__ == "__main__":
    main()
