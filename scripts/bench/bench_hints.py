"""Hinted against blind: the real frame (tests/data/realsky_azi45.png) as a TIFF and a FITS
file solved blind, with only ``--ra/--dec/--radius`` and a scale range, and (FITS) from
its own header's WCS with no option at all.

The header's WCS is made from the frame's reference pointing (tests/data/README.md,
tetra3's) and the nominal 11.42 deg width, with no rotation: a header that knows roughly
where the camera pointed, as a telescope's control software writes it, and DATE-OBS
(so that frame's attitude is corrected for aberration; its blind row is given the same
time with --time). Each case runs in
a fresh Python process per repeat (``startrack identify``, as a user runs it), after one
warm-up run that fills the database cache; the process first imports what every case
imports (startrack, astropy's WCS and coordinates), then times the command: ``command s``
covers reading the frame, loading the catalog and the (cached) tables, solving and the
aberration correction; ``identify ms`` is the record's ``timing_ms.identify``.

    .venv/bin/python scripts/bench/bench_hints.py [--repeats 3]
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
FRAME = ROOT / "tests" / "data" / "realsky_azi45.png"
POINTING = (355.2046, 58.1518)  # tests/data/README.md
DATE_OBS = "2019-07-29T20:47:26"
HINT = ["--ra", "355", "--dec", "58", "--radius", "2", "--scale-low", "10",
        "--scale-high", "13"]


def write_frames(folder: Path) -> dict[str, Path]:
    """The frame as a TIFF, a FITS file without WCS and one with a WCS header."""
    import tifffile
    from astropy.io import fits
    from astropy.wcs import WCS

    from startrack.io import read_image

    image = read_image(FRAME)
    paths = {"tiff": folder / "azi45.tiff", "fits": folder / "azi45.fits",
             "fits_wcs": folder / "azi45_wcs.fits"}
    tifffile.imwrite(paths["tiff"], image)
    fits.PrimaryHDU(image).writeto(paths["fits"])
    wcs = WCS(naxis=2)
    wcs.wcs.ctype = ["RA---TAN", "DEC--TAN"]
    wcs.wcs.crpix = [image.shape[1] / 2 + 0.5, image.shape[0] / 2 + 0.5]
    wcs.wcs.crval = list(POINTING)
    scale = 11.42 / image.shape[1]
    wcs.wcs.cdelt = [-scale, scale]
    header = wcs.to_header()
    header["DATE-OBS"] = DATE_OBS
    fits.PrimaryHDU(image, header=header).writeto(paths["fits_wcs"])
    return paths


#: run in a fresh process: the imports every case shares first, then the command timed
TIMED = """
import sys, time
from click.testing import CliRunner
import astropy.coordinates, astropy.wcs, startrack.cli._identify, startrack.solver._pipeline
from startrack.cli import main
t0 = time.perf_counter()
out = CliRunner().invoke(main, ["identify", *sys.argv[1:], "--format", "json"])
print(time.perf_counter() - t0)
print(out.output.splitlines()[0])
"""


def run(args: list[str]) -> tuple[float, dict]:
    """(seconds from the command's start to its answer, the imports done; the record)."""
    out = subprocess.run([sys.executable, "-c", TIMED, *args], capture_output=True,
                         text=True, cwd=ROOT)
    seconds, line = out.stdout.splitlines()[:2]
    return float(seconds), json.loads(line)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    opts = parser.parse_args()
    from startrack.bench import git_commit

    with tempfile.TemporaryDirectory() as tmp:
        paths = write_frames(Path(tmp))
        cases = [
            ("TIFF, blind", [str(paths["tiff"])]),
            ("TIFF, --ra/--dec/--radius + scale range", [str(paths["tiff"]), *HINT]),
            ("FITS, blind (--no-header-hints)", [str(paths["fits"]), "--no-header-hints"]),
            ("FITS, --ra/--dec/--radius + scale range", [str(paths["fits"]), *HINT]),
            ("FITS with a WCS header, no options", [str(paths["fits_wcs"])]),
            ("the same, blind (--no-header-hints --time DATE-OBS)", [
                str(paths["fits_wcs"]), "--no-header-hints", "--time", DATE_OBS]),
        ]
        print(f"# scripts/bench/bench_hints.py --repeats {opts.repeats} (commit {git_commit()})")
        print("| case | solved | method | stars | RA | Dec | identify ms | command s (median) |")
        print("|---|---|---|---|---|---|---|---|")
        for name, args in cases:
            run(args)  # warm-up: fills the database cache
            walls, records = zip(*(run(args) for _ in range(opts.repeats)), strict=True)
            rec = records[-1]
            att = rec["attitude"] or {}
            ident = statistics.median(r["timing_ms"]["identify"] for r in records)
            print(f"| {name} | {rec['status']} | {rec['method']} | {len(rec['stars'])} | "
                  f"{att.get('ra_deg', np.nan):.4f} | {att.get('dec_deg', np.nan):.4f} | "
                  f"{ident:.0f} | {statistics.median(walls):.2f} |")


if __name__ == "__main__":
    main()
