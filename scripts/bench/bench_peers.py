"""Peers against our methods: tetra3, tetra3rs and astrometry.net (their solve call; for
astrometry.net the solve-field process) beside hybrid/pyramid; a peer not installed is skipped.

Same frames for every method (scripts/bench/bench_identify.py's make_frames: Hipparcos, random
attitudes, brightest first, false stars at random ranks), two conditions. For the peers the
time is their solve call alone (``MatchDiagnostics.method_ms``); "ident" adds our
verification of their answer. A solution is wrong when it misidentifies the field: boresight
more than 1 arcmin off, or a real star given another star's id. Two further counts: "false
id" (a false star given the id of a catalog star within the verification radius: the shared
verification's doing, the same for every method) and "strict" (bench_identify's criterion:
whole attitude within 1 arcmin and every id right; at 1 px noise the roll alone is often off
by more than 1 arcmin, so "strict" then counts correct answers too). Then our hybrid/pyramid
identify is profiled on the same frames.

    .venv/bin/python scripts/bench/bench_peers.py --frames 100
"""

from __future__ import annotations

import argparse
import cProfile
import io
import pstats
import sys

import numpy as np

from scripts.bench.bench_identify import is_wrong, make_frames  # noqa: E402
from startrack.attitude import boresight_error_arcsec  # noqa: E402
from startrack.camera import Camera  # noqa: E402
from startrack.database import StarDatabase  # noqa: E402
from startrack.errors import InputError  # noqa: E402
from startrack.matchers import MatcherConfig, available_methods, get_matcher  # noqa: E402
from startrack.sky import SkySpec, load_sky  # noqa: E402
from startrack.solver import identify  # noqa: E402
from startrack.verify import VerifyConfig  # noqa: E402

PEERS = ("tetra3", "tetra3rs", "astrometry")
CONDITIONS = ((0.3, 0, 0.0), (1.0, 5, 0.2))  # noise px, false stars, missing fraction


def misidentified(sol, frame) -> bool:
    truth = frame.truth_rows[sol.obs_index]
    real = truth >= 0
    return (boresight_error_arcsec(sol.rotation, frame.rotation) > 60.0
            or bool(np.any(truth[real] != sol.cat_index[real])))


def run(matcher, frames, verify) -> dict:
    ident, solve, solved, wrong, false_id, strict = [], [], 0, 0, 0, 0
    for frame in frames:
        sol = identify(frame.obs, matcher, verify)
        ident.append(sol.identify_ms)
        solve.append(sol.identify_ms if sol.diagnostics.method_ms is None
                      else sol.diagnostics.method_ms)
        if sol.solved:
            solved += 1
            wrong += int(misidentified(sol, frame))
            false_id += int(np.any(frame.truth_rows[sol.obs_index] < 0))
            strict += int(is_wrong(sol, frame))
    ident, solve = np.array(ident), np.array(solve)
    return {"solved": solved, "wrong": wrong, "false_id": false_id, "strict": strict,
            "median": float(np.median(solve)),
            "p95": float(np.percentile(solve, 95)), "ident_median": float(np.median(ident)),
            "ident_p95": float(np.percentile(ident, 95))}


def profile(matcher, frames, verify, top: int) -> str:
    prof = cProfile.Profile()
    prof.enable()
    for frame in frames:
        identify(frame.obs, matcher, verify)
    prof.disable()
    out = io.StringIO()
    pstats.Stats(prof, stream=out).sort_stats("cumulative").print_stats(top)
    lines = out.getvalue().splitlines()
    start = next((i for i, line in enumerate(lines) if "ncalls" in line), 0)
    return "\n".join(lines[start:])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=100)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--ours", default="hybrid,pyramid", help="our methods (those present)")
    ap.add_argument("--min-sep-px", type=float, default=3.0,
                    help="merge catalog stars closer than this (as bench_identify)")
    ap.add_argument("--profile-frames", type=int, default=50,
                    help="frames per condition to profile our methods on (0: no profile)")
    ap.add_argument("--top", type=int, default=15)
    args = ap.parse_args(argv)

    camera = Camera.from_fov(1024, 1024, 20.0)
    spec = SkySpec(kind="hipparcos", mag_limit=6.5,
                   min_separation_deg=args.min_sep_px * np.degrees(1.0 / camera.f_px))
    catalog = load_sky(spec)
    database = StarDatabase(catalog, camera)
    ours = [m for m in args.ours.split(",") if m in available_methods()]
    matchers = {}
    for name in ours + list(PEERS):
        try:
            matcher = get_matcher(name)(database, MatcherConfig())
            matcher.prepare()
        except InputError as exc:
            print(f"skipping {name}: {exc}", file=sys.stderr)
            continue
        matchers[name] = matcher
    verify = VerifyConfig()
    print(f"Hipparcos Hp <= 6.5 ({len(catalog)} stars), FOV 20 deg, 1024x1024, "
          f"{args.frames} frames per condition (seed {args.seed}); peer times are their "
          f"solve call, 'ident' adds our verification")
    all_frames = {}
    for noise, false, missing in CONDITIONS:
        frames = make_frames(catalog, camera, args.frames, args.seed, noise, false, missing,
                             noise)
        all_frames[(noise, false, missing)] = frames
        print(f"\n== {noise} px noise, {false} false stars, {missing:.0%} missing")
        print(f"{'method':<9} {'solved':>6} {'wrong':>5} {'false id':>8} {'strict':>6} "
              f"{'median ms':>9} {'p95 ms':>8} {'ident med':>9} {'ident p95':>9}")
        rows = {}
        for name, matcher in matchers.items():
            r = rows[name] = run(matcher, frames, verify)
            print(f"{name:<9} {r['solved']:>6} {r['wrong']:>5} {r['false_id']:>8} "
                  f"{r['strict']:>6} {r['median']:>9.3f} "
                  f"{r['p95']:>8.3f} {r['ident_median']:>9.3f} {r['ident_p95']:>9.3f}")
        # Reliable: no misidentified field. Its solved count is in the table above.
        reliable = [n for n in ours if n in rows and rows[n]["wrong"] == 0]
        if reliable:
            best = min(reliable, key=lambda n: rows[n]["median"])
            for peer in PEERS:
                if peer in rows:
                    ratio = rows[best]["median"] / rows[peer]["median"]
                    print(f"median time ratio {best} / {peer}: {ratio:.2f}")
        else:
            print("no method of ours with 0 wrong in this condition")
    if args.profile_frames > 0:
        for name in ours:
            if name not in matchers:
                continue
            for cond, frames in all_frames.items():
                print(f"\n== profile {name}, {cond[0]} px / {cond[1]} false / {cond[2]:.0%} "
                      f"missing, {args.profile_frames} frames (cumulative)")
                print(profile(matchers[name], frames[:args.profile_frames], verify, args.top))
    return 0


if __name__ == "__main__":
    sys.exit(main())
