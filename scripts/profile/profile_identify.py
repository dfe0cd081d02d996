"""Profile one method's identify on one benchmark condition: cProfile's top functions.

The frames are scripts/bench/bench_identify.py's (and so bench_peers.py's, for the same seed,
count and condition). Prints the solved/wrong count and median time, then the profile.

    .venv/bin/python scripts/profile/profile_identify.py --method pyramid --noise-px 1 \
        --false-stars 5 --missing 0.2 --frames 50 --sort tottime
    .venv/bin/python scripts/profile/profile_identify.py --method pyramid --param
    pattern_per_region=10
    .venv/bin/python scripts/profile/profile_identify.py --method pyramid --junk 100   # the
    "no" path
    .venv/bin/python scripts/profile/profile_identify.py --method pyramid --noise-px 0.3 \
        --false-stars 3 --missing 0.1 --fov-tolerance 0.025 --fov-error 0.025  # nominal FOV

With ``--fov-tolerance`` the frames are solved as ``startrack identify`` solves them,
told the FOV ``--fov-error`` off (scripts/bench/bench_identify.py's pipeline): the refit of a
nominal FOV, or its search, is profiled too.
With ``--kernels`` the time inside each compiled entry point is clocked instead of
profiled (scripts/profile/_kernel_clock.py), and what share of the identify time they make:

    .venv/bin/python scripts/profile/profile_identify.py --method quad --noise-px 0.3 \
        --false-stars 3 --missing 0.1 --fov-tolerance 0.025 --fov-error 0.025 --kernels

With ``--junk N`` the frames are N random centroid sets instead (4-60 points, no star
pattern: scripts/validation/false_positives.py's), where every hypothesis must be refused.
"""

from __future__ import annotations

import argparse
import ast
import cProfile
import io
import pstats
import sys

import numpy as np

from scripts.bench.bench_identify import Frame, make_frames, pipeline_solver  # noqa: E402
from scripts.bench.bench_peers import misidentified  # noqa: E402
from scripts.profile import _kernel_clock  # noqa: E402
from scripts.validation.false_positives import random_sets  # noqa: E402
from startrack.attitude import boresight_error_arcsec  # noqa: E402
from startrack.camera import Camera  # noqa: E402
from startrack.database import StarDatabase  # noqa: E402
from startrack.matchers import MatcherConfig, get_matcher  # noqa: E402
from startrack.sky import SkySpec, load_sky  # noqa: E402
from startrack.solver import identify  # noqa: E402
from startrack.verify import VerifyConfig  # noqa: E402


def _param(text: str) -> tuple[str, object]:
    key, _, value = text.partition("=")
    try:
        return key, ast.literal_eval(value)
    except (ValueError, SyntaxError):
        return key, value


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--method", default="pyramid")
    ap.add_argument("--param", action="append", default=[], type=_param,
                    help="method parameter key=value (repeatable)")
    ap.add_argument("--frames", type=int, default=50)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--noise-px", type=float, default=1.0)
    ap.add_argument("--false-stars", type=int, default=5)
    ap.add_argument("--missing", type=float, default=0.2)
    ap.add_argument("--max-stars", type=int, default=MatcherConfig().max_stars)
    ap.add_argument("--min-sep-px", type=float, default=3.0)
    ap.add_argument("--sort", default="tottime", help="pstats sort key (tottime, cumulative)")
    ap.add_argument("--top", type=int, default=25)
    ap.add_argument("--no-profile", action="store_true", help="time only")
    ap.add_argument("--fov-tolerance", type=float, default=None,
                    help="solve as `startrack identify --fov-tolerance` does (the pipeline)")
    ap.add_argument("--fov-error", type=float, default=0.0,
                    help="with --fov-tolerance: the told FOV is this fraction off")
    ap.add_argument("--kernels", action="store_true",
                    help="clock the compiled entry points instead of profiling")
    ap.add_argument("--junk", type=int, default=0,
                    help="profile the 'no' on this many random centroid sets instead")
    args = ap.parse_args(argv)
    if args.kernels:
        args.no_profile = True

    camera = Camera.from_fov(1024, 1024, 20.0)
    catalog = load_sky(SkySpec(kind="hipparcos", mag_limit=6.5,
                               min_separation_deg=args.min_sep_px * np.degrees(1 / camera.f_px)))
    frames = make_frames(catalog, camera, args.frames, args.seed, args.noise_px,
                         args.false_stars, args.missing, args.noise_px)
    if args.junk:
        frames = [Frame(obs, np.full(len(obs), -1), None)
                  for obs in random_sets(camera, args.junk, args.seed, 4, 60, args.noise_px)]
    matcher = get_matcher(args.method)(StarDatabase(catalog, camera),
                                       MatcherConfig(max_stars=args.max_stars),
                                       **dict(args.param))
    matcher.prepare()
    verify = VerifyConfig()
    def solve(frame: Frame):
        return identify(frame.obs, matcher, verify)

    def wrong_answer(sol, frame: Frame) -> bool:
        return misidentified(sol, frame)

    if args.fov_tolerance is not None:
        spec = SkySpec(kind="hipparcos", mag_limit=6.5)
        through = pipeline_solver(args.method, camera, spec, args.fov_error,
                                  args.fov_tolerance, args.max_stars, args.noise_px)

        answered = {}

        def solve(frame: Frame):
            result = through(frame)
            answered[id(frame)] = result.catalog
            return result.solution

        def wrong_answer(sol, frame: Frame) -> bool:
            # the pipeline loads its own catalog: the same stars by id, not by row
            ids = answered[id(frame)].ids[sol.cat_index]
            truth = frame.truth_rows[sol.obs_index]
            real = truth >= 0
            return (boresight_error_arcsec(sol.rotation, frame.rotation) > 60.0
                    or bool(np.any(catalog.ids[truth[real]] != ids[real])))

    solve(frames[0])  # compiled kernels loaded before timing
    if args.kernels:  # once every stage is loaded: the clocks wrap the names they call
        _kernel_clock.install()
    _kernel_clock.reset()
    prof = cProfile.Profile()
    times, solved, wrong, hyps = [], 0, 0, []
    for frame in frames:
        if not args.no_profile:
            prof.enable()
        sol = solve(frame)
        prof.disable()
        times.append(sol.identify_ms)
        hyps.append(sol.diagnostics.hypotheses)
        solved += int(sol.solved)
        wrong += int(sol.solved and wrong_answer(sol, frame))
    t = np.array(times)
    what = (f"{args.junk} random centroid sets, sigma {args.noise_px} px" if args.junk else
            f"{args.noise_px} px, {args.false_stars} false, {args.missing:.0%} missing, "
            f"{args.frames} frames")
    print(f"{args.method} {dict(args.param)}: {what}: solved {solved}, wrong "
          f"{wrong}, median {np.median(t):.2f} ms, p95 {np.percentile(t, 95):.2f} ms, "
          f"max {t.max():.1f} ms, hypotheses/frame {np.mean(hyps):.1f}")
    if args.kernels:
        print(_kernel_clock.report(len(frames), float(t.sum())))
    if not args.no_profile:
        out = io.StringIO()
        pstats.Stats(prof, stream=out).sort_stats(args.sort).print_stats(args.top)
        lines = out.getvalue().splitlines()
        start = next((i for i, line in enumerate(lines) if "ncalls" in line), 0)
        print("\n".join(lines[start:]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
