"""Time the refit of a nominal FOV: the camera fit alone and the whole refit of a solved frame.

A frame solved at a nominal field of view has its focal length fitted to its identified
stars and its pointing verified again through the fitted camera
(:func:`startrack.solver._fov_refit.refit_fov`, the fit
:func:`startrack.solver._fov_fit.fit_camera`). The
frames are scripts/bench/bench_identify.py's, simulated with the true camera and solved with a
camera whose FOV is ``--fov-error`` off. Each step is warmed up on the first frame before
anything is timed; the figures are per solved frame.

    .venv/bin/python scripts/bench/bench_fov_refit.py --frames 100 --fov-error 0.005
"""

from __future__ import annotations

import sys
from types import SimpleNamespace

import numpy as np

from scripts._cli import add_camera, add_frames, script_parser  # noqa: E402
from scripts.bench._timing import median_us  # noqa: E402
from scripts.bench.bench_identify import make_frames  # noqa: E402
from startrack.camera import Camera  # noqa: E402
from startrack.match_records import Observation  # noqa: E402
from startrack.sky import UNRESOLVED_PIXELS, SkySpec, load_sky  # noqa: E402
from startrack.solver import (
    Identifier,  # noqa: E402
    fit_camera,  # noqa: E402
    refit_fov,  # noqa: E402
)


def main(argv: list[str] | None = None) -> int:
    ap = script_parser(__doc__)
    add_frames(ap, 100, seed=0)
    add_camera(ap, noise_px=0.3)
    ap.add_argument("--fov-error", type=float, default=0.005,
                    help="the nominal FOV is this fraction wider than the true one")
    ap.add_argument("--method", default="pyramid")
    ap.add_argument("--repeats", type=int, default=20, help="timed calls per frame")
    args = ap.parse_args(argv)

    true = Camera.from_fov(args.size, args.size, args.fov)
    nominal = Camera.from_fov(args.size, args.size, args.fov * (1.0 + args.fov_error))
    spec = SkySpec(kind="hipparcos", mag_limit=6.5,
                   min_separation_deg=UNRESOLVED_PIXELS * np.degrees(1.0 / true.f_px))
    catalog = load_sky(spec, true)
    frames = make_frames(catalog, true, args.frames, args.seed, args.noise_px, 3, 0.1,
                         args.noise_px)
    ident = Identifier(nominal, catalog, args.method, sigma_px=args.noise_px)
    solved = []
    for frame in frames:
        obs = Observation.from_pixels(frame.obs.x, frame.obs.y, nominal, args.noise_px)
        sol = ident.identify(obs)
        if sol.solved:
            solved.append(SimpleNamespace(solution=sol, obs=obs, camera=nominal,
                                          sigma_px=args.noise_px, catalog=catalog))
    if not solved:
        print("no frame solved at the nominal FOV", file=sys.stderr)
        return 1
    db, vc = ident.database, ident.verify_config
    cat = db.vectors

    def fit(r):
        return lambda: fit_camera(r.camera, r.obs.x[r.solution.obs_index],
                                  r.obs.y[r.solution.obs_index], cat[r.solution.cat_index])

    def refit(r):
        return lambda: refit_fov(r, db, vc)

    fit(solved[0])()  # warm-up: every kernel and lazy table before the clock
    refit(solved[0])()
    fit_us = [median_us(fit(r), args.repeats) for r in solved]
    refit_us = [median_us(refit(r), args.repeats) for r in solved]
    kept = sum(refit_fov(r, db, vc) is not None for r in solved)
    print(f"{len(solved)} of {len(frames)} frames solved by {args.method} at a nominal FOV "
          f"{args.fov_error:+.1%} off ({args.fov} deg, {args.size} px, "
          f"{args.noise_px} px noise, seed {args.seed}); refit kept {kept}")
    print(f"fit_camera (the focal-length fit): median {np.median(fit_us):.1f} us, "
          f"p95 {np.percentile(fit_us, 95):.1f} us per frame")
    print(f"refit_fov (fit + verification through the fitted camera): median "
          f"{np.median(refit_us):.1f} us, p95 {np.percentile(refit_us, 95):.1f} us per frame")
    return 0


if __name__ == "__main__":
    sys.exit(main())
