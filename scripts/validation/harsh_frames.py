"""Harsh frames: wrong attitudes, wrong reported identities and withheld identities per method.

The frames are the bench's (startrack.bench._frames.make_frame, the frames `startrack
compare` scores), by default 200 Hipparcos frames (Hp <= 6.5, 20 deg, 1024 x 1024; stars
closer than 2 px merged by load_sky, as the optics cannot split them) at 1 px centroid
noise, 5 false stars and 20% of the stars missing.

Counted per method over the frames:

* ``wrong att``: solved frames whose boresight is off by more than max(60", 5 sigma), the
  bench's threshold (startrack.bench._metrics).
* ``wrong id``: reported identities whose catalog row is not the observed star's true row
  (a false star given an id counts); ``unres`` of them are the true star's unresolved twin:
  the reported catalog star lies within 2 px (UNRESOLVED_PIXELS) of the true one.
* ``withheld``: real observed stars whose true catalog star projects within the match
  radius at the solved attitude but that the solution leaves unidentified (the cost of
  leaving an ambiguous star unidentified rather than guessing).

The observed stars carry the bench's fluxes (exact unless ``--mag-noise``), which the final
labelling checks against the catalog magnitudes.

``--pipeline`` solves each frame's centroids (x, y, flux) through :class:`startrack.Solver`
instead, the path of ``startrack identify`` and the API: the camera's FOV taken as nominal
(the default ``--fov-tolerance``), its first look at the brightest stars, the refit and
the search, and the evidence gate on every answer; with ``--scale LO,HI`` the FOV is given
as a range instead, LO to HI times the true one (``--scale-low/--scale-high``); with
``--fov-off F`` the camera is given with F times the true FOV (a nominal FOV off by F - 1,
the default tolerance searching it).

    .venv/bin/python scripts/validation/harsh_frames.py --frames 200 --seed 0
    .venv/bin/python scripts/validation/harsh_frames.py --frames 200 --seed 0 --methods pyramid
    --pipeline
    .venv/bin/python scripts/validation/harsh_frames.py --frames 200 --pipeline --scale 0.6,1.7
    .venv/bin/python scripts/validation/harsh_frames.py --frames 200 --pipeline --fov-off 1.04
"""

from __future__ import annotations

import argparse
import dataclasses
import sys

import numpy as np
from scipy.spatial import cKDTree

from scripts._cli import add_camera, add_frames, script_parser
from startrack.attitude import boresight_error_arcsec
from startrack.bench import DEFAULT_THRESHOLD_ARCSEC, NOISE_SIGMAS, Condition, make_frame
from startrack.camera import Camera
from startrack.sky import UNRESOLVED_PIXELS, SkySpec, load_sky
from startrack.solver import Identifier, identify
from startrack.verify import VerifyConfig

METHODS = "angle,triangle,hybrid,radial,pyramid"


def _pixels(camera: Camera, rotation, vectors: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    x, y, _ = camera.vector_to_pixel(rotation.inv().apply(vectors).reshape(-1, 3))
    return x, y


def score(frame, solution, catalog, camera: Camera, radius_px: float) -> dict:
    """The counts of one solved frame (see the module docstring)."""
    truth = frame.truth_rows
    sigma_as = float(np.degrees(frame.obs.sigma_rad)) * 3600.0
    limit = max(DEFAULT_THRESHOLD_ARCSEC, NOISE_SIGMAS * sigma_as)
    out = {"solved": 1, "wrong_att": int(boresight_error_arcsec(solution.rotation,
                                                                frame.rotation) > limit)}
    reported = truth[solution.obs_index]
    bad = reported != solution.cat_index
    out["ids"] = len(solution.obs_index)
    out["wrong_id"] = int(bad.sum())
    out["false_id"] = int(np.count_nonzero(bad & (reported < 0)))
    unres = 0
    for k in np.flatnonzero(bad & (reported >= 0)):
        sep = np.arccos(np.clip(catalog.vectors[reported[k]] @
                                catalog.vectors[solution.cat_index[k]], -1, 1))
        unres += int(sep * camera.f_px < UNRESOLVED_PIXELS)
    out["unres"] = unres
    real = np.flatnonzero(truth >= 0)
    cx, cy = _pixels(camera, solution.rotation, catalog.vectors[truth[real]])
    near = np.hypot(cx - frame.obs.x[real], cy - frame.obs.y[real]) <= radius_px
    out["withheld"] = int(np.count_nonzero(near & ~np.isin(real, solution.obs_index)))
    out["identifiable"] = int(np.count_nonzero(near))
    return out


def run(args: argparse.Namespace) -> int:
    camera = Camera.from_fov(args.size, args.size, args.fov)
    catalog = load_sky(SkySpec(kind="hipparcos", mag_limit=args.mag_limit), camera)
    condition = Condition(noise_px=args.noise_px, false_stars=args.false_stars,
                          missing=args.missing, mag_noise=args.mag_noise)
    frames = [make_frame(catalog, camera, condition, args.seed, i) for i in range(args.frames)]
    print(f"Hipparcos Hp <= {args.mag_limit} ({len(catalog)} stars after merging pairs closer "
          f"than {UNRESOLVED_PIXELS} px), {args.fov} deg {args.size} px, {args.frames} bench "
          f"frames (seed {args.seed}): {args.noise_px} px noise, {args.false_stars} false "
          f"stars, {args.missing:.0%} missing, {args.mag_noise} mag photometric noise, "
          f"{args.max_stars} stars per matcher"
          + ("" if args.fov_off is None or not args.pipeline else
             f"; the camera given as {args.fov * args.fov_off:g} deg ({args.fov_off:g}x)"))
    keys = ["solved", "wrong_att", "ids", "wrong_id", "false_id", "unres", "withheld",
            "identifiable"]
    head = (f"{'method':<9} {'solved':>7} {'wrong att':>9} {'ids':>6} {'wrong id':>8} "
            f"{'false':>5} {'unres':>5} {'withheld':>8} {'identifiable':>12}")
    print(head)
    print("-" * len(head))
    config = VerifyConfig()
    for name in [m.strip() for m in args.methods.split(",") if m.strip()]:
        solve = (_through_pipeline(camera, catalog, args, name) if args.pipeline else
                 _through_matcher(Identifier(camera, catalog, name, max_stars=args.max_stars),
                                  config))
        total = dict.fromkeys(keys, 0)
        where, unsolved = [], []
        for i, frame in enumerate(frames):
            solution = solve(frame)
            if not solution.solved:
                unsolved.append(i)
                continue
            counts = score(frame, solution, catalog, camera, config.radius_px(frame.obs))
            for key in keys:
                total[key] += counts[key]
            if counts["wrong_att"] or counts["wrong_id"]:
                where.append(i)
        print(f"{name:<9} {total['solved']:>7} {total['wrong_att']:>9} {total['ids']:>6} "
              f"{total['wrong_id']:>8} {total['false_id']:>5} {total['unres']:>5} "
              f"{total['withheld']:>8} {total['identifiable']:>12}")
        if where:
            print(f"    frames with a wrong attitude or identity: {where[:20]}")
        if unsolved:
            print(f"    frames not solved: {unsolved[:20]}")
    return 0


def _through_matcher(ident: Identifier, config: VerifyConfig):
    return lambda frame: identify(frame.obs, ident.matcher, config)


def _through_pipeline(camera: Camera, catalog, args: argparse.Namespace, method: str):
    """Each frame's centroids solved by startrack.Solver (the identify command's path);
    its answer as the matcher's Solution, in the catalog rows load_sky gives."""
    from startrack import Solver
    from startrack.solver import Pipeline

    given = {"camera": camera if args.fov_off is None else Camera.from_fov(
        camera.width, camera.height, args.fov * args.fov_off)}
    if args.scale:  # the FOV as a range (--scale-low/--scale-high), no camera
        low, high = (float(v) * args.fov for v in args.scale.split(","))
        given = {"size": (args.size, args.size), "scale_low": low, "scale_high": high}
    solver = Solver(**given, sky="hipparcos", mag_limit=args.mag_limit, method=method,
                    max_stars=args.max_stars, sigma_px=args.noise_px or 0.5)
    pipeline: Pipeline = solver._solver  # no track, no prior: the one-frame pipeline

    def solve(frame):
        obs = frame.obs
        spots = np.column_stack([obs.x, obs.y, obs.flux])
        result = pipeline.solve(as_frame_input(spots))
        return in_rows_of(catalog, result.catalog, result.solution)

    return solve


def in_rows_of(catalog, theirs, solution):
    """``solution`` (rows of the catalog ``theirs``) in the rows of ``catalog``: the same
    sky cut for another camera (a range's centre) merges other close pairs, so its rows
    differ; each reported star is ``catalog``'s row nearest it (its own, or its twin's
    where only one catalog merged them)."""
    if theirs is catalog or not solution.solved or len(theirs) == len(catalog) and \
            np.array_equal(theirs.ids, catalog.ids):
        return solution
    _, rows = cKDTree(catalog.vectors).query(theirs.vectors[solution.cat_index])
    return dataclasses.replace(solution, cat_index=np.asarray(rows, np.int64))


def as_frame_input(spots: np.ndarray):
    from startrack.api import as_frame_input as api_input

    return api_input(spots)


def main(argv: list[str] | None = None) -> int:
    ap = script_parser(__doc__)
    ap.add_argument("--methods", default=METHODS)
    add_frames(ap, 200, seed=0)
    ap.add_argument("--mag-limit", type=float, default=6.5)
    add_camera(ap, noise_px=1.0)
    ap.add_argument("--false-stars", type=int, default=5)
    ap.add_argument("--missing", type=float, default=0.2)
    ap.add_argument("--mag-noise", type=float, default=0.0,
                    help="1-sigma error of the observed magnitudes (fluxes)")
    ap.add_argument("--max-stars", type=int, default=8)
    ap.add_argument("--pipeline", action="store_true",
                    help="solve through startrack.Solver (identify's path), not the matcher")
    ap.add_argument("--scale", default=None, metavar="LO,HI",
                    help="with --pipeline: the FOV given as the range LO to HI times the "
                         "true FOV (identify's --scale-low/--scale-high), not the camera")
    ap.add_argument("--fov-off", type=float, default=None, metavar="F",
                    help="with --pipeline: the camera given with F times the true FOV "
                         "(a nominal FOV off by F - 1)")
    args = ap.parse_args(argv)
    if (args.scale or args.fov_off is not None) and not args.pipeline:
        ap.error("--scale and --fov-off solve through the pipeline: add --pipeline")
    if args.scale and args.fov_off is not None:
        ap.error("--scale gives no camera for --fov-off to put off: give one of them")
    return run(args)


if __name__ == "__main__":
    sys.exit(main())
