"""Regenerate the README's results: run `startrack compare` on the Hipparcos preset and
write its summary between the README's results markers, with the command, the commit and
the date it ran at; and write what docs/results.md shows of the two papers (each section's
verdicts and stamp, from the tables saved in docs/data/) between the papers markers.
Nothing in either is typed by hand.

    .venv/bin/python scripts/docs/readme_results.py                      # ours only
    .venv/bin/python scripts/docs/readme_results.py --papers-only        # the papers' lines only
    PYTHONPATH=. /work/peers-venv/bin/python scripts/docs/readme_results.py \
        --methods angle,triangle,hybrid,radial,pyramid,tetra3,tetra3rs  # with the peers

Writes out/readme/ (the compare run) and README.md.
"""

from __future__ import annotations

import shlex
import subprocess
import sys
from pathlib import Path

import pandas as pd

from scripts._cli import add_frames, script_parser
from startrack.bench import summary_table

ROOT = Path(__file__).resolve().parents[2]
START, END = "<!-- results:start -->", "<!-- results:end -->"
PAPERS_START, PAPERS_END = "<!-- papers:start -->", "<!-- papers:end -->"
DEFAULT_METHODS = "angle,triangle,hybrid,radial,pyramid"


def compare_args(methods: str, frames: int, jobs: int, out: Path) -> list[str]:
    return ["compare", "--config", "configs/hipparcos20.toml", "--methods", methods,
            "--noise-px", "0.3,1.0", "--false-stars", "0,5", "--missing", "0,0.2",
            "--grid", "full", "--frames", str(frames), "--max-stars", "8",
            "--jobs", str(jobs), "--out", str(out), "--no-resume"]


def section(summary: pd.DataFrame, command: str, commit: str, date: str) -> str:
    return (f"{START}\nMeasured {date} at commit `{commit}` on this project's 2-core machine "
            f"with\n`{command}`\n(written by `scripts/docs/readme_results.py`). Times are our "
            "identify call (matching, verification, attitude); for the peers, their solve "
            "call alone; rates with their 95% Wilson intervals.\n\n"
            + summary_table(summary) + f"\n{END}")


def papers_section() -> str:
    """The README's lines on the two papers: what each section of docs/results.md says
    (scripts/papers/_results_doc.py's summaries, from the saved tables)."""
    from scripts.papers import _results_doc

    lines = [f"* {_results_doc.section_summary(s)}" for s in _results_doc.SECTIONS]
    return (f"{PAPERS_START}\n`docs/results.md` re-runs the two papers' experiments, their "
            "literal variants beside ours, and judges each claim with paired tests by the "
            "rules it opens with (`scripts/papers/_verdicts.py`): *reproduced*, *reproduced only "
            "under* named conditions (never counted as reproduced), *not reproduced*, "
            "*reversed*, *not testable here*. It is rendered by `scripts/papers/_results_doc.py` "
            "from the tables each paper's script saves in `docs/data/`; these lines, from "
            "the same verdicts, by `scripts/docs/readme_results.py --papers-only` (`make "
            "results` runs all three):\n\n"
            + "\n".join(lines) + f"\n{PAPERS_END}")


def replace_block(text: str, start: str, end: str, block: str) -> str | None:
    """``text`` with the part from ``start`` to ``end`` replaced by ``block`` (which
    carries both markers); None when the markers are missing."""
    if start not in text or end not in text:
        return None
    head, rest = text.split(start, 1)
    return head + block + rest.split(end, 1)[1]


def write_papers() -> int:
    text = (ROOT / "README.md").read_text()
    new = replace_block(text, PAPERS_START, PAPERS_END, papers_section())
    if new is None:
        print(f"README.md has no {PAPERS_START} ... {PAPERS_END} markers", file=sys.stderr)
        return 2
    (ROOT / "README.md").write_text(new)
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = script_parser(__doc__)
    ap.add_argument("--methods", default=DEFAULT_METHODS)
    add_frames(ap, 100)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", type=Path, default=ROOT / "out" / "readme")
    ap.add_argument("--papers-only", action="store_true",
                    help="only the papers' lines, from docs/data/ (no compare run)")
    args = ap.parse_args(argv)
    if args.papers_only:
        return write_papers()
    from startrack.bench import git_commit, provenance

    commit = git_commit() or "?"  # the code the numbers come from, before anything changes
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
    return write_papers()


if __name__ == "__main__":
    sys.exit(main())
