"""Regenerate docs/figures.md and its images: the annotated real frame
(`identify --annotate`) and the compare plots of the README's Hipparcos comparison, stamped
with the commands, the commit and the date they ran at. Nothing is drawn by hand.

    .venv/bin/python scripts/docs/docs_figures.py            # about 2-4 minutes on 2 cores

Writes docs/figures/annotated_azi45.png, docs/figures/compare_*.png, docs/figures.md
(the compare run itself goes to out/docs-figures/).
"""

from __future__ import annotations

import argparse
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
FIGURES = ROOT / "docs" / "figures"
ANNOTATED = FIGURES / "annotated_azi45.png"
IDENTIFY = ["identify", "tests/data/realsky_azi45.png", "--fov", "11.42", "--sky",
            "hipparcos", "--epoch", "2019.6", "--annotate", "docs/figures/annotated_azi45.png",
            "-q"]


def compare_args(frames: int, out: Path) -> list[str]:
    """The README's comparison (pyramid, triangle, radial on Hipparcos, full grid)."""
    return ["compare", "--config", "configs/hipparcos20.toml", "--methods",
            "pyramid,triangle,radial", "--noise-px", "0.3,1", "--false-stars", "0,5",
            "--missing", "0,0.2", "--grid", "full", "--frames", str(frames),
            "--max-stars", "8", "--out", str(out), "--no-resume", "-q"]


def _run(args: list[str]) -> None:
    print("+ startrack " + shlex.join(args), file=sys.stderr)
    subprocess.run([sys.executable, "-m", "startrack", *args], cwd=ROOT, check=True,
                   stdout=subprocess.DEVNULL)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=200)
    ap.add_argument("--out", type=Path, default=ROOT / "out" / "docs-figures")
    args = ap.parse_args(argv)
    from startrack.bench import git_commit, provenance

    commit = git_commit() or "?"  # the code the figures come from
    FIGURES.mkdir(parents=True, exist_ok=True)
    ANNOTATED.unlink(missing_ok=True)  # identify refuses to replace an output
    _run(IDENTIFY)
    cmp_args = compare_args(args.frames, args.out)
    _run(cmp_args)
    plots = sorted(args.out.glob("plot_*.png")) + sorted(args.out.glob("heatmap_*.png"))
    for old in FIGURES.glob("compare_*.png"):
        old.unlink()
    copied = []
    for plot in plots:
        target = FIGURES / f"compare_{plot.name}"
        shutil.copyfile(plot, target)
        copied.append(target)
    when = provenance("")["date (UTC)"] + " UTC"
    shown_cmp = "startrack " + shlex.join(c for c in cmp_args if c != "-q")
    shown_cmp = shown_cmp.replace(str(args.out), "out/docs-figures")
    lines = ["# Figures", "",
             f"Made {when} at commit `{commit}` by `scripts/docs/docs_figures.py`.", "",
             "## The annotated frame", "",
             f"`startrack {shlex.join(c for c in IDENTIFY if c != '-q')}`", "",
             "Identified stars circled and labelled, the other spots faint squares, residuals "
             "magnified (factor and scale bar in the caption), the RA/Dec grid and the "
             "north/east compass from the solved WCS.", "",
             "![annotated frame](figures/annotated_azi45.png)", "",
             "## The compare plots", "", f"`{shown_cmp}`", ""]
    lines += [f"![{p.stem}](figures/{p.name})\n" for p in copied]
    (ROOT / "docs" / "figures.md").write_text("\n".join(lines))
    print(f"wrote {ANNOTATED.relative_to(ROOT)}, {len(copied)} compare plot(s), "
          "docs/figures.md", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
