"""Regenerate the README's results table: run `startrack compare` on the Hipparcos preset
and write its summary between the README's results markers, with the command, the commit
and the date it ran at. Nothing in that table is typed by hand.

    .venv/bin/python scripts/readme_results.py                      # ours only
    PYTHONPATH=. /work/peers-venv/bin/python scripts/readme_results.py \
        --methods angle,triangle,hybrid,radial,pyramid,tetra3,tetra3rs  # with the peers

Writes out/readme/ (the compare run) and README.md.
"""

from __future__ import annotations

import argparse
import shlex
import subprocess
import sys
from pathlib import Path

import pandas as pd

from startrack.bench.report import summary_table

ROOT = Path(__file__).resolve().parents[1]
START, END = "<!-- results:start -->", "<!-- results:end -->"
DEFAULT_METHODS = "angle,triangle,hybrid,radial,pyramid"


def compare_args(methods: str, frames: int, jobs: int, out: Path) -> list[str]:
    return ["compare", "--config", "configs/hipparcos20.toml", "--methods", methods,
            "--noise-px", "0.3,1.0", "--false-stars", "0,5", "--missing", "0,0.2",
            "--grid", "full", "--frames", str(frames), "--max-stars", "8",
            "--jobs", str(jobs), "--out", str(out), "--no-resume"]


def section(summary: pd.DataFrame, command: str, commit: str, date: str) -> str:
    return (f"{START}\nMeasured {date} at commit `{commit}` on this project's 2-core machine "
            f"with\n`{command}`\n(written by `scripts/readme_results.py`). Times are our "
            "identify call (matching, verification, attitude); for the peers, their solve "
            "call alone; rates with their 95% Wilson intervals.\n\n"
            + summary_table(summary) + f"\n{END}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--methods", default=DEFAULT_METHODS)
    ap.add_argument("--frames", type=int, default=100)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", type=Path, default=ROOT / "out" / "readme")
    args = ap.parse_args(argv)
    from startrack.bench.report import _git_commit, provenance

    commit = _git_commit() or "?"  # the code the numbers come from, before anything changes
    cli = compare_args(args.methods, args.frames, args.jobs, args.out)
    run = subprocess.run([sys.executable, "-m", "startrack", *cli], cwd=ROOT)
    if run.returncode != 0:
        return run.returncode
    summary = pd.read_csv(args.out / "summary.csv")
    command = "startrack " + shlex.join(cli[:cli.index("--out")])
    text = (ROOT / "README.md").read_text()
    if START not in text or END not in text:
        print(f"README.md has no {START} ... {END} markers", file=sys.stderr)
        return 2
    head, rest = text.split(START, 1)
    tail = rest.split(END, 1)[1]
    when = provenance(command)["date (UTC)"] + " UTC"
    (ROOT / "README.md").write_text(head + section(summary, command, commit, when) + tail)
    print(summary_table(summary))
    return 0


if __name__ == "__main__":
    sys.exit(main())
