"""Write docs/simulation.md: the effects' keys, the presets, real frames against their
simulations (table, images, histograms), the feature table and how to measure speed.

Run: .venv/bin/python scripts/docs/doc_simulation.py [--real-dir DIR] [--compare-dir DIR]

Real frames: tests/data/realsky_azi45.png always; with --real-dir, every *.tif/*.tiff/*.png
in DIR too (e.g. the four tetra3 frames). Each is solved by startrack (config realsky),
simulated with configs/blackfly_s_imx265.toml at that attitude and compared
(startrack.bench._real_frames). --compare-dir: a finished `startrack compare` run whose
report.md summary is quoted. The command and commit are stamped in the document.
"""

from __future__ import annotations

import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np

from scripts._cli import script_parser

ROOT = Path(__file__).resolve().parents[2]
DOC = ROOT / "docs" / "simulation.md"
FIGURES = ROOT / "docs" / "figures"
TEST_FRAME = ROOT / "tests" / "data" / "realsky_azi45.png"


def _commit() -> str:
    out = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"],
                         capture_output=True, text=True, check=False).stdout.strip()
    dirty = subprocess.run(["git", "-C", str(ROOT), "status", "--porcelain", "startrack"],
                           capture_output=True, text=True, check=False).stdout.strip()
    return (out or "unknown") + ("+dirty" if dirty else "")


def _frames(real_dir: str | None) -> list[Path]:
    """The test frame, then the folder's frames but the one the test frame copies."""
    from startrack.io import read_image

    frames = [TEST_FRAME]
    if real_dir:
        test_pixels = read_image(TEST_FRAME)
        for path in sorted(Path(real_dir).iterdir()):
            if path.suffix.lower() in (".tif", ".tiff", ".png") and not np.array_equal(
                    read_image(path), test_pixels):
                frames.append(path)
    return frames


def _figure(name: str, real: np.ndarray, sim: np.ndarray) -> str:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
    lo, hi = np.percentile(real, [1, 99.7])
    for ax, img, title in ((axes[0], real, "real"), (axes[1], sim, "simulated")):
        ax.imshow(img, cmap="gray", vmin=lo, vmax=hi)
        ax.set_title(f"{title} ({name})")
        ax.axis("off")
    bins = np.linspace(0, 65535, 200)
    for img, label in ((real, "real"), (sim, "simulated")):
        axes[2].hist(img.ravel(), bins=bins, histtype="step", log=True, label=label)
    axes[2].set_xlabel("ADU")
    axes[2].set_ylabel("pixels")
    axes[2].legend()
    axes[2].set_title("pixel histogram")
    fig.tight_layout()
    path = FIGURES / f"simulation_{name}.png"
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path.name


def real_frames_section(frames: list[Path]) -> list[str]:
    import startrack
    from startrack.bench import REALSKY_PRESET, check_frame
    from startrack.io import read_image
    from startrack.simulate import load_config
    from startrack.sky import load_sky

    config = load_config(REALSKY_PRESET)
    catalog = load_sky(config.sky, config.camera)
    lines = []
    for path in frames:
        image = read_image(path)
        solution = startrack.solve(path, config="realsky")
        if not solution.solved:
            lines += [f"### {path.name}", "", "not solved by startrack: left out.", ""]
            continue
        name = path.stem.replace("2019-07-29T204726_", "")
        sim, rows = check_frame(image, config, solution.rotation, catalog)
        fig = _figure(name, image, sim)
        lines += [f"### {name}", "",
                  f"Solved attitude: RA {solution.ra_deg:.4f}, Dec {solution.dec_deg:.4f}, "
                  f"roll {solution.roll_deg:.2f} deg.", "",
                  "| quantity | real | simulated | tolerance | within |", "|---|---|---|---|---|"]
        lines += [f"| {r.quantity} | {r.real:.4g} | {r.simulated:.4g} | {r.tolerance} | "
                  f"{'yes' if r.ok else '**no**'} |" for r in rows]
        lines += ["", f"![real and simulated {name}](figures/{fig})", ""]
    return lines


def effect_keys_section() -> list[str]:
    from startrack.simulate import TABLES, documented

    lines = []
    for name, cls in TABLES.items():
        lines += [f"`[{name}]`", "", "| key | default and range | meaning |", "|---|---|---|"]
        lines += [f"| `{k}` | {d} | {m} |" for k, d, m in documented(cls)]
        lines.append("")
    return lines


def compare_section(compare_dir: str | None) -> list[str]:
    if not compare_dir:
        return ["(run with --compare-dir to quote a run)", ""]
    report = (Path(compare_dir) / "report.md").read_text().splitlines()
    command = next((ln for ln in report if ln.startswith("| command |")), "")
    commit = next((ln for ln in report if ln.startswith("| git commit |")), "")
    start, end = report.index("## Summary"), report.index("## Plots")
    table = [ln for ln in report[start:end] if ln.startswith("|")]
    plots = []
    for plot in sorted(Path(compare_dir).glob("plot_*.png")):
        target = FIGURES / f"simulation_compare_{plot.name}"
        shutil.copyfile(plot, target)
        plots.append(f"![{plot.stem}](figures/{target.name})")
    return [f"Run: `{command.split('|')[2].strip()}` at commit "
            f"{commit.split('|')[2].strip()} (its report.md; 95% Wilson intervals).", "",
            *table, "", *plots, ""]


def main() -> None:
    parser = script_parser(__doc__)
    parser.add_argument("--real-dir")
    parser.add_argument("--compare-dir")
    args = parser.parse_args()
    command = shlex.join(["python", "scripts/docs/doc_simulation.py", *sys.argv[1:]])
    template = (ROOT / "scripts" / "data" / "simulation_template.md").read_text()
    text = template.format(
        stamp=f"Generated by `{command}` at commit {_commit()}.",
        keys="\n".join(effect_keys_section()),
        real="\n".join(real_frames_section(_frames(args.real_dir))),
        compare="\n".join(compare_section(args.compare_dir)))
    DOC.write_text(text)
    print(f"wrote {DOC.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
