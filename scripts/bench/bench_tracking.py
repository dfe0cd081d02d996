"""The tracking bench: prints its tables and writes docs/tracking.md and its figures.

1. The issue's sequence: 200 frames at 10 fps turning at (1, 0.5, 2) deg/s, 0.5 px noise,
   2 false stars and 10% of the stars missing per frame (Hipparcos, configs/hipparcos20.toml):
   solved, wrong, frames by mode, and the median identify time of tracking against
   lost-in-space on the same frames.
2. A sequence with a 1 s lens-cap gap (blank frames) followed by a 10 deg jump: where lock
   is lost and where it is reacquired.
3. Sweeps of rate (0 to 10 deg/s), noise, false and missing stars (``compare --mode
   tracking``'s conditions), with tetra3rs's tracking mode (``attitude_hint``) beside ours
   where it is installed.

Run it with the peers' venv to include tetra3rs:
    PYTHONPATH=. /work/peers-venv/bin/python scripts/bench/bench_tracking.py
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from scripts.profile.profile_tracking import report as profile_report  # noqa: E402
from startrack.bench import _tracking_bench as tb
from startrack.bench import _tracking_images as ti
from startrack.bench import _tracking_report as tr
from startrack.io import atomic_text
from startrack.simulate import load_config
from startrack.sky import load_sky, resolve_sky
from startrack.solver import Identifier

ROOT = Path(__file__).resolve().parents[2]


def _commit() -> str:
    try:
        out = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, text=True,
                             capture_output=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"],
                               cwd=ROOT, text=True, capture_output=True).stdout.strip()
        return out + (" (with uncommitted changes)" if dirty else "")
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def _base(catalog, camera, idents, peer, frames, seed, interleaved=True):
    seq = tb.make_sequence(catalog, camera, tb.TrackCondition(), frames, 10.0, seed)
    df = tb.run_sequence(seq, tb.runners_for(idents, peer), interleaved=interleaved)
    summary = tb.summarise_tracking(df.assign(condition=0), ["condition", "method"])
    modes = df.groupby(["method", "mode"]).size().unstack(fill_value=0)
    return df, summary, modes


def base_runners(frames: int, seed: int):
    """Section 1's sequence (Hipparcos 20 deg, 10 fps) and, by name, the makers of
    startrack's runners over it (pyramid): its tracker ("tracked frames") and its lost in
    space alone, each a fresh one per call (as run_sequence starts them)."""
    cfg = load_config(ROOT / "configs" / "hipparcos20.toml")
    catalog = load_sky(resolve_sky(cfg.sky, cfg.camera), cfg.camera)
    ident = Identifier(cfg.camera, catalog, "pyramid")
    seq = tb.make_sequence(catalog, cfg.camera, tb.TrackCondition(), frames, 10.0, seed)
    return seq, {"tracked frames": lambda: tb.ours(ident),
                 "lost in space": lambda: tb.lost_in_space(ident)}


def sequence_summary(frames: int, seed: int, interleaved: bool = True) -> pd.DataFrame:
    """Section 1's sequence (Hipparcos 20 deg) through pyramid tracked and alone, and
    tetra3rs hinted and alone where it is installed: one summary row per method
    (``interleaved``: :func:`startrack.bench._tracking_bench.run_sequence`'s)."""
    cfg = load_config(ROOT / "configs" / "hipparcos20.toml")
    catalog = load_sky(resolve_sky(cfg.sky, cfg.camera), cfg.camera)
    idents = {"pyramid": Identifier(cfg.camera, catalog, "pyramid")}
    return _base(catalog, cfg.camera, idents, tb.peer_available(), frames, seed,
                 interleaved)[1]


def _events(catalog, camera, idents, peer, seed):
    seq = tb.make_sequence(catalog, camera, tb.TrackCondition(), 60, 10.0, seed,
                           blank=(20, 30), jump_at=30, jump_deg=10.0)
    df = tb.run_sequence(seq, tb.runners_for(idents, peer))
    return df


def _event_rows(df) -> str:
    lines = ["| method | frames 0-19 | 20 (cap on) | 21-29 | 30 (cap off, 10 deg jump) | "
             "31 | 32-59 |", "|---|---|---|---|---|---|---|"]
    for method, g in df.groupby("method", sort=False):
        if not tb.is_tracking_method(str(method)):
            continue
        g = g.sort_values("frame")
        states = tr.lock_states(g["solved"].to_numpy(bool), (g["mode"] == "tracking").to_numpy())
        right = g["correct"].to_numpy(bool)

        def span(a, b, states=states, right=right):
            got = sorted(set(states[a:b]))
            return "/".join(got) + ("" if right[a:b].all() or not any(
                s in ("tracking", "acquired", "reacquired") for s in got) else " (WRONG)")
        lines.append(f"| {method} | {span(0, 20)} | {span(20, 21)} | {span(21, 30)} | "
                     f"{span(30, 31)} | {span(31, 32)} | {span(32, 60)} |")
    return "\n".join(lines)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=200, help="frames of the base sequence")
    parser.add_argument("--sweep-frames", type=int, default=100, help="frames per sweep point")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--docs", type=Path, default=ROOT / "docs")
    args = parser.parse_args()
    commit = _commit()  # before anything is written: the code the figures come from
    cfg = load_config(ROOT / "configs" / "hipparcos20.toml")
    camera = cfg.camera
    spec = resolve_sky(cfg.sky, camera)
    catalog = load_sky(spec, camera)
    peer = tb.peer_available()
    idents = {"pyramid": Identifier(camera, catalog, "pyramid")}
    figures = args.docs / "figures"
    figures.mkdir(parents=True, exist_ok=True)

    base_df, base, modes = _base(catalog, camera, idents, peer, args.frames, args.seed)
    ratio = _ratio_text(base.set_index("method")["time_median_ms"])
    base_md = tr.markdown_table(base)
    modes_md = "```\n" + modes.to_string() + "\n```"
    print("## 1. The issue's sequence\n" + base_md + "\n\nframes by mode:\n" + modes.to_string()
          + f"\n\nlost-in-space / tracking median identify time, same frames: {ratio}\n")

    profile_md = profile_report(catalog, camera, args.frames, args.seed)
    print("## Where the time goes\n" + profile_md + "\n")

    images = ti.run_images(catalog, spec, camera, cfg.sensor, tb.TrackCondition(),
                           args.frames, 10.0, args.seed)
    images_md = _images_table(ti.summarise_images(images))
    print("## Rendered frames, through identify\n" + images_md + "\n")

    ev = _events(catalog, camera, idents, peer, args.seed + 1)
    ev_md = _event_rows(ev)
    timeline = tr.plot_timeline(ev, figures / "tracking_gap_jump.png",
                                "1 s lens cap (frames 20-29), then a 10 deg jump (frame 30)")
    base_plot = tr.plot_timeline(base_df, figures / "tracking_base_sequence.png",
                                 f"{args.frames} frames at 10 fps, (1, 0.5, 2) deg/s, 0.5 px, "
                                 "2 false stars, 10% missing")
    print("## 2. Gap and jump\n" + ev_md + "\n")

    conditions = tb.oat_conditions(tr.parse_tracking_levels({}))
    _, sweep = tb.run_tracking_bench(catalog, camera, conditions, tuple(idents),
                                     args.sweep_frames, 10.0, args.seed + 2, peer,
                                     progress=lambda m: print(m, file=sys.stderr))
    plots = tr.plot_sweeps(sweep, conditions, figures)
    sweep_md = tr.markdown_table(sweep)
    ratio_md = tr.markdown_table_ratio(tr.time_ratios(sweep))
    print("## 3. Sweeps\n" + sweep_md + "\n\n" + ratio_md)
    _write_doc(args, commit, peer, base_md, modes_md, ratio, ev_md, sweep_md, ratio_md,
               [base_plot, timeline, *plots], profile_md, images_md)
    return 0


def _images_table(summary) -> str:
    lines = ["| FOV as given | run | frames | solved | tracked | wrong | median identify ms | "
             "median centroid ms | lost-in-space / tracking |", "|---" * 9 + "|"]
    for r in summary.itertuples():
        lines.append(f"| {r.fov} | {r.run} | {r.frames} | {r.solved} | {r.tracked} | {r.wrong} "
                     f"| {r.identify_ms:.3f} | {r.centroid_ms:.2f} | {r.lis_over_track:.1f}x |")
    return "\n".join(lines)


def _ratio_text(median_ms) -> str:
    """Lost-in-space over tracking, ours and (where it ran) tetra3rs's hint mode."""
    text = f"**{median_ms['pyramid'] / median_ms['pyramid+track']:.1f}x** (pyramid)"
    if tb.PEER in median_ms and tb.PEER_LIS in median_ms:
        text += (f", {median_ms[tb.PEER_LIS] / median_ms[tb.PEER]:.1f}x (tetra3rs: its "
                 "lost-in-space over its `attitude_hint` mode)")
    return text


def _write_doc(args, commit, peer, base_md, modes_md, ratio, ev_md, sweep_md, ratio_md, plots,
               profile_md, images_md):
    cmd = "PYTHONPATH=. /work/peers-venv/bin/python scripts/bench/bench_tracking.py"
    if (args.frames, args.sweep_frames, args.seed) != (200, 100, 0):
        cmd += f" --frames {args.frames} --sweep-frames {args.sweep_frames} --seed {args.seed}"
    figs = "\n".join(f"![{p.stem}](figures/{p.name})" for p in plots)
    text = f"""# Tracking

<!-- generated by scripts/bench/bench_tracking.py: do not edit by hand -->

Generated by `{cmd}` at commit {commit}, numpy {np.__version__}; tetra3rs
{"installed (its `attitude_hint` tracking mode, `strict_hint=True`, then its lost-in-space)"
 if peer else "not installed in this environment"}. Hipparcos Hp <= 6.5, 20 deg 1024 x 1024
camera (configs/hipparcos20.toml). Centroids are the true positions plus noise, so the
times are identify times alone; each method runs on the same frame one after the other.
`pyramid+track` is startrack's tracker (`identify --track`) falling back to `pyramid`;
`pyramid` is lost-in-space on every frame. "wrong": a solution whose boresight is more than
60" off or that names a star wrongly. A loss of lock is a frame after a solved one that is
not solved by tracking; "reacquire" counts the frames from there to the next solution
(0: lost-in-space solved that same frame).

## Use

```sh
startrack simulate --config configs/hipparcos20.toml --frames 50 --fps 10 --rate 1,0.5,2 \
    --out out/seq                        # one trajectory: frame k at R0 exp(w k / fps)
startrack simulate --fps 10 --profile slew.csv --out out/slew   # t,qw,qx,qy,qz; SLERP
startrack identify --track --format json out/seq/frame_*.png    # mode and lock per record
startrack identify --prior 80,20,30 --prior-sigma-deg 0.5 frame.png
startrack compare --mode tracking --config configs/hipparcos20.toml --out out/track
```

```python
solver = startrack.Solver(fov_deg=20.0, track=True)   # state kept between frames
for frame in frames:
    s = solver.solve(frame)                           # s.mode, s.lock
solver.reset()                                        # a new sequence
```

Inputs of a sequence are taken as evenly spaced in time, in the order given. Each frame is
predicted from the last two solved ones; the match window comes from the prediction's
uncertainty. The prediction is tested as its own hypothesis: every star of the frame is
evidence for it, and the number within the window of a catalog star must be one that an
unrelated frame gives with no more than verification's false-match probability (the same
binomial bound, over the window's area). When the window is too wide for that, three-star
hypotheses from a vote on the image displacement pass lost-in-space's own test
(`startrack/tracking/_tracked_solve.py`). Either way the frame is then refined and labelled as
lost-in-space's accepted hypothesis is; failing both, it falls back to lost-in-space.
Lost-in-space frames of `identify --track` are solved as a single input is (a nominal FOV
refitted, an unknown one searched for, a deep narrow-field sky by the quad search), and
the frames after one are tracked through the camera it fitted.

## The issue's sequence

{args.frames} frames at 10 fps, (1, 0.5, 2) deg/s, 0.5 px noise, 2 false stars and 10%
missing per frame.

{base_md}

Frames by mode:

{modes_md}

Median identify time, lost-in-space over tracking, on the same frames: {ratio}.
Both modes count the same span: the prediction (tracking), matching, verification, the
attitude, its quaternion and the residuals, not the building of the Solution and its
Rotation object. A tracked frame's refinement and labelling are lost-in-space's own;
tracking saves the pattern search and the hypotheses' first tests. The methods run one
after the other on each frame, so each finds the processor's caches holding the others'
work, as a tracker finds them after the image has been read and centroided.

## Where the time goes

From `scripts/profile/profile_tracking.py` (run here on the same sequence; pyramid):

{profile_md}

## Rendered frames, through `identify`

The same trajectory and seed, drawn by the sensor model (the motion blur of the rate over
the exposure, 10% of the stars missing, 2 false stars per frame) and solved from the
images as `startrack identify --track` and `startrack identify` solve files
(`startrack/bench/_tracking_images.py`): centroids from each frame, then the camera as the
user gives it. With the FOV nominal (`--fov-tolerance 0.1`, the default) every
lost-in-space solve fits the FOV again, which a tracked frame does not need: it keeps the
camera its sequence fitted. With the FOV given as exact (`--fov-tolerance 0`),
lost-in-space is matching and verification alone, as in the tables above. "wrong": the
boresight more than 60" off (identities are checked in the centroid-list tables).

{images_md}

## Lens cap and jump

60 frames: the cap is on for 1 s (frames 20-29: no stars), and the attitude has jumped by
10 deg when it comes off (frame 30). Lock states per span of frames:

{ev_md}

## Sweeps (`startrack compare --mode tracking`)

{args.sweep_frames} frames per sequence; one variable at a time around the sequence above.

{sweep_md}

Lost-in-space median time over tracking's, on the same frames:

{ratio_md}

{figs}
"""
    with atomic_text(args.docs / "tracking.md") as fh:
        fh.write(text)
    print(f"\nwrote {args.docs / 'tracking.md'} and {len(plots)} figure(s) in "
          f"{args.docs / 'figures'}")


if __name__ == "__main__":
    sys.exit(main())
