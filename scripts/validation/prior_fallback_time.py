"""Time of a wrong prior against plain lost-in-space, in one process (issue: a stale prior
must fall back within a few lost-in-space times).

    python scripts/validation/prior_fallback_time.py [--frames 6] [--seed 3]

Simulates Hipparcos frames (20 deg, random attitudes), then solves each with a
``startrack.Solver`` without prior and with ``prior=(0, 0, 0)`` (pointing elsewhere) at
several sigmas. Each solver is warmed on the first frame (compiling and loading are
one-time costs, docs/conventions.md), then the wall time of ``solve`` per frame is
printed with the ratio to lost-in-space and how many frames reported ``fallback``.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SIGMAS_DEG = (0.001, 0.1, 1.0, 10.0)


def _frames(folder: Path, count: int, seed: int) -> list[Path]:
    subprocess.run([sys.executable, "-m", "startrack", "simulate", "--sky", "hipparcos",
                    "--config", "hipparcos20", "--frames", str(count + 1), "--seed",
                    str(seed), "--out", str(folder)], check=True, capture_output=True)
    return sorted(folder.glob("frame_*.png"))


def _time(solver, frames: list[Path]) -> tuple[float, int, int]:
    """(mean ms per frame, frames solved, frames with a fallback) after one warm-up."""
    solver.solve(frames[0])
    t0 = time.perf_counter()
    results = [solver.solve(f) for f in frames[1:]]
    ms = (time.perf_counter() - t0) * 1000.0 / max(len(results), 1)
    return (ms, sum(r.solved for r in results),
            sum("fallback" in r.to_dict() for r in results))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=6)
    parser.add_argument("--seed", type=int, default=3)
    opts = parser.parse_args()
    import startrack

    with tempfile.TemporaryDirectory() as tmp:
        frames = _frames(Path(tmp), opts.frames, opts.seed)
        lis_ms, solved, _ = _time(startrack.Solver(), frames)
        print(f"{opts.frames} Hipparcos frames (seed {opts.seed}); per frame, warm:")
        print(f"  lost-in-space:                 {lis_ms:8.0f} ms  ({solved} solved)")
        for sigma in SIGMAS_DEG:
            ms, solved, fell = _time(startrack.Solver(prior=(0.0, 0.0, 0.0),
                                                      prior_sigma_deg=sigma), frames)
            print(f"  prior 0,0,0 sigma {sigma:6g} deg: {ms:8.0f} ms  ({ms / lis_ms:.2f} x "
                  f"lost-in-space; {solved} solved, {fell} with fallback)")


if __name__ == "__main__":
    main()
