"""Run every real frame through `startrack identify` as a user does, beside solve-field.

Each frame of the given folders is solved twice by the installed `startrack` command, one
process per frame and mode, with the default sky: with its field of view given 4 % high
(`--fov`, the default tolerance) and with no field of view at all. `solve-field`
(astrometry.net, Tycho-2 index files) is given the same information: the same scale
range (``--scale-units degwidth``, the FOV given times 1 -/+ the tolerance) or none.
Every run is timed and its peak memory read by ``/usr/bin/time -v``.

A folder is read through its ``manifest.csv`` (file, fov_deg, ra_deg, dec_deg,
tolerance_arcsec, ...: the image-centre pointing of a reference solution), or through the
``--references`` CSV for folders without one. A frame is *correct* when the boresight is
within its tolerance of the reference, *wrong* when solved farther off.

    scripts/bench/bench_real_frames.py FOLDER [FOLDER ...] [--references CSV] [--no-peer]
        [--timeout 300] [--write docs/real.md]
"""

from __future__ import annotations

import csv
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from scripts._cli import script_parser
from scripts.bench.bench_blind import provenance_line

ROOT = Path(__file__).resolve().parents[2]
#: The FOV a user gives: 4 % high, inside the default tolerance.
FOV_HIGH = 1.04
#: The scale range solve-field is given around that FOV: the default tolerance's.
TOLERANCE = 0.10
#: Reference tolerance when a folder's references give none (arcsec).
DEFAULT_TOLERANCE_ARCSEC = 60.0
IMAGE_SUFFIXES = {".png", ".jpg", ".jpeg", ".tif", ".tiff", ".fits", ".fit"}


@dataclass(frozen=True)
class Frame:
    """One real frame and its reference pointing (image centre, ICRS)."""

    path: Path
    fov_deg: float
    ra_deg: float
    dec_deg: float
    tolerance_arcsec: float


@dataclass
class Run:
    """One solver's answer on one frame in one mode."""

    solved: bool = False
    error_arcsec: float = float("nan")
    wall_s: float = float("nan")
    peak_mb: float = float("nan")
    why: str = ""
    extra: dict = field(default_factory=dict)


def read_frames(folders: list[Path], references: Path | None) -> list[Frame]:
    """The frames of ``folders`` that have a reference pointing."""
    rows: dict[str, dict] = {}
    for source in [references] if references else []:
        with open(source, newline="") as fh:
            rows.update({r["file"]: r for r in csv.DictReader(fh)})
    frames = []
    for folder in folders:
        manifest = folder / "manifest.csv"
        here = dict(rows)
        if manifest.is_file():
            with open(manifest, newline="") as fh:
                here.update({r["file"]: r for r in csv.DictReader(fh)})
        for path in sorted(folder.iterdir()):
            row = here.get(path.name)
            if path.suffix.lower() not in IMAGE_SUFFIXES or row is None:
                continue
            frames.append(Frame(path, float(row["fov_deg"]), float(row["ra_deg"]),
                                float(row["dec_deg"]),
                                float(row.get("tolerance_arcsec") or DEFAULT_TOLERANCE_ARCSEC)))
    return frames


def separation_arcsec(ra1, dec1, ra2, dec2) -> float:
    """The angle between two ICRS directions (deg in, arcsec out)."""
    a1, d1, a2, d2 = np.radians([ra1, dec1, ra2, dec2])
    c = np.sin(d1) * np.sin(d2) + np.cos(d1) * np.cos(d2) * np.cos(a1 - a2)
    return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))) * 3600.0)


def timed(cmd: list[str], timeout: float) -> tuple[subprocess.CompletedProcess | None, float,
                                                     float]:
    """Run ``cmd`` under /usr/bin/time -v: (process or None on timeout, wall s, peak MB)."""
    t0 = time.perf_counter()
    # its own process group, so that a timeout ends the solver too, not only `time`
    with subprocess.Popen(["/usr/bin/time", "-v", *cmd], stdout=subprocess.PIPE,
                          stderr=subprocess.PIPE, text=True, start_new_session=True) as child:
        try:
            out, err = child.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            os.killpg(child.pid, signal.SIGKILL)
            child.communicate()
            return None, time.perf_counter() - t0, float("nan")
    wall = time.perf_counter() - t0
    proc = subprocess.CompletedProcess(cmd, child.returncode, out, err)
    peak = re.search(r"Maximum resident set size \(kbytes\): (\d+)", proc.stderr)
    return proc, wall, (int(peak.group(1)) / 1024.0 if peak else float("nan"))


def startrack_run(frame: Frame, with_fov: bool, timeout: float) -> Run:
    """`startrack identify FRAME [--fov F] --format json` as a user types it."""
    exe = shutil.which("startrack") or str(Path(sys.executable).with_name("startrack"))
    cmd = [exe, "identify", str(frame.path), "--format", "json"]
    if with_fov:
        cmd += ["--fov", f"{frame.fov_deg * FOV_HIGH:.4f}"]
    proc, wall, peak = timed(cmd, timeout)
    run = Run(wall_s=wall, peak_mb=peak)
    if proc is None:
        run.why = f"killed at {timeout:g} s"
        return run
    try:
        record = json.loads(proc.stdout.strip().splitlines()[-1])
    except (IndexError, json.JSONDecodeError):
        run.why = f"exit {proc.returncode}: " + (proc.stderr.strip().splitlines() or ["?"])[0]
        return run
    run.solved = record.get("status") == "solved"
    if not run.solved:
        run.why = str(record.get("reason") or record.get("status") or "not solved")
        return run
    att = record["attitude"]
    run.error_arcsec = separation_arcsec(att["ra_deg"], att["dec_deg"], frame.ra_deg,
                                         frame.dec_deg)
    run.extra = {"stars": len(record.get("stars") or []), "fov": record.get("fov_deg")}
    return run


def solve_field_run(frame: Frame, with_fov: bool, timeout: float) -> Run:
    """`solve-field` on the same frame with the same scale information (or none)."""
    exe = shutil.which("solve-field")
    if exe is None:
        return Run(why="solve-field not installed")
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [exe, "--overwrite", "--no-plots", "--no-verify", "--crpix-center",
               "--dir", tmp, "--new-fits", "none", "--cpulimit", f"{timeout:g}",
               "--out", "frame", str(frame.path)]
        if with_fov:
            f = frame.fov_deg * FOV_HIGH
            cmd += ["--scale-units", "degwidth", "--scale-low", f"{f * (1 - TOLERANCE):.4f}",
                    "--scale-high", f"{f * (1 + TOLERANCE):.4f}"]
        proc, wall, peak = timed(cmd, timeout + 30.0)
        run = Run(wall_s=wall, peak_mb=peak)
        wcs_file = Path(tmp) / "frame.wcs"
        if proc is None or not wcs_file.is_file():
            run.why = "killed" if proc is None else "no solution"
            return run
        from astropy.io import fits
        from astropy.wcs import WCS

        header = fits.getheader(wcs_file)
        w, h = header.get("IMAGEW"), header.get("IMAGEH")
        ra, dec = WCS(header).all_pix2world([[(w - 1) / 2.0, (h - 1) / 2.0]], 0)[0]
        run.solved = True
        run.error_arcsec = separation_arcsec(ra, dec, frame.ra_deg, frame.dec_deg)
        return run


def verdict(run: Run, frame: Frame) -> str:
    if not run.solved:
        return "no"
    return "yes" if run.error_arcsec <= frame.tolerance_arcsec else "WRONG"


def cell(run: Run, frame: Frame) -> str:
    v = verdict(run, frame)
    if v == "no":
        return f"no ({run.why})"
    return f"{v} {run.error_arcsec:.0f}\""


def summary(results, mode: str, solver: str) -> str:
    runs = [(f, r[(mode, solver)]) for f, r in results if (mode, solver) in r]
    if not runs:
        return ""
    right = sum(verdict(r, f) == "yes" for f, r in runs)
    wrong = sum(verdict(r, f) == "WRONG" for f, r in runs)
    walls = [r.wall_s for _, r in runs]
    peaks = [r.peak_mb for _, r in runs if np.isfinite(r.peak_mb)]
    return (f"| {mode} | {solver} | {right}/{len(runs)} | {wrong} | {np.median(walls):.2f} | "
            f"{max(walls):.1f} | {np.median(peaks) if peaks else float('nan'):.0f} | "
            f"{max(peaks) if peaks else float('nan'):.0f} |")


def markdown(results, solvers: list[str], stamp: str) -> str:
    lines = ["# Real frames", "", stamp, "",
             "Every real frame, one `startrack identify FRAME --format json` process per frame "
             "and mode, the default sky, as a user runs it: *with FOV* gives `--fov` 4 % above "
             "the reference's (inside the default tolerance), *blind* gives none. "
             "`solve-field` is given the same scale range (the tolerance's) or none. "
             "*Correct*: the image-centre pointing within the frame's tolerance of the "
             "reference (astrometry.net's solution, cross-checked by tetra3rs); *WRONG*: "
             "solved farther off. Wall time and peak memory by `/usr/bin/time -v`, the "
             "whole process. *again* (with `--again`): the same command run a second time "
             "right after, when the on-disk caches hold the tables the first run built for "
             "that camera: the cost from a camera's second frame on.", "",
             "| mode | solver | correct | wrong | median wall s | max wall s | median peak MB "
             "| max peak MB |", "|---|---|---|---|---|---|---|---|"]
    for mode in ("fov", "blind", "fov again", "blind again"):
        lines += [s for s in (summary(results, mode, solver) for solver in solvers) if s]
    head = ["frame", "FOV deg"]
    for mode in ("fov", "blind"):
        for solver in solvers:
            head += [f"{solver} {mode}", "s", "MB"]
    lines += ["", "Per frame: the answer (the boresight's error against the reference, or "
              "why it failed), wall seconds and peak MB.", "",
              "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for frame, runs in results:
        row = [frame.path.name, f"{frame.fov_deg:.2f}"]
        for mode in ("fov", "blind"):
            for solver in solvers:
                r = runs.get((mode, solver))
                row += ([cell(r, frame), f"{r.wall_s:.1f}", f"{r.peak_mb:.0f}"] if r
                        else ["", "", ""])
        lines.append("| " + " | ".join(row) + " |")
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = script_parser(__doc__)
    ap.add_argument("folders", nargs="+", type=Path)
    ap.add_argument("--references", type=Path, default=ROOT / "scripts" / "data"
                    / "real_sky_references.csv",
                    help="CSV of file, fov_deg, ra_deg, dec_deg[, tolerance_arcsec] for "
                         "folders without a manifest.csv")
    ap.add_argument("--solvers", default="startrack,solve-field",
                    help="comma-separated: startrack, solve-field")
    ap.add_argument("--peer-cache", type=Path,
                    help="JSON of solve-field's runs: read where it holds a frame and mode, "
                         "written with the new ones (solve-field does not change with "
                         "startrack's commit)")
    ap.add_argument("--cached-peer-only", action="store_true",
                    help="solve-field's rows from --peer-cache alone (none run here)")
    ap.add_argument("--modes", default="fov,blind")
    ap.add_argument("--only", default="", help="a substring of the frames to run")
    ap.add_argument("--timeout", type=float, default=300.0, help="seconds per run")
    ap.add_argument("--write", type=Path, help="write the markdown table here")
    ap.add_argument("--again", action="store_true",
                    help="run each startrack command a second time right after the first "
                         "(the caches then hold what the first run built) and summarise "
                         "those runs too, as mode 'fov again' / 'blind again'")
    args = ap.parse_args()
    frames = [f for f in read_frames(args.folders, args.references) if args.only in f.path.name]
    solvers = args.solvers.split(",")
    peer_cache = {}
    if args.peer_cache and args.peer_cache.is_file():
        peer_cache = json.loads(args.peer_cache.read_text())
    modes = args.modes.split(",")
    started, load0, t0 = time.strftime("%Y-%m-%d %H:%M", time.gmtime()), os.getloadavg()[0], \
        time.time()
    results = []
    for frame in frames:
        runs = {}
        for mode in modes:
            if "startrack" in solvers:
                runs[(mode, "startrack")] = startrack_run(frame, mode == "fov", args.timeout)
                if args.again:
                    runs[(f"{mode} again", "startrack")] = startrack_run(
                        frame, mode == "fov", args.timeout)
            if "solve-field" in solvers:
                key = f"{frame.path.name}/{mode}"
                if key not in peer_cache and args.cached_peer_only:
                    continue
                if key not in peer_cache:
                    run = solve_field_run(frame, mode == "fov", args.timeout)
                    peer_cache[key] = {k: getattr(run, k) for k in
                                       ("solved", "error_arcsec", "wall_s", "peak_mb", "why")}
                    peer_cache[key]["measured"] = time.strftime("%Y-%m-%d %H:%M UTC",
                                                                time.gmtime())
                    if args.peer_cache:
                        args.peer_cache.write_text(json.dumps(peer_cache, indent=1))
                cached = peer_cache[key]
                runs[(mode, "solve-field")] = Run(cached["solved"], cached["error_arcsec"],
                                                  cached["wall_s"], cached["peak_mb"],
                                                  cached["why"])
        results.append((frame, runs))
        print(frame.path.name, " ".join(f"{m}/{s}: {cell(r, frame)} {r.wall_s:.1f}s "
                                        f"{r.peak_mb:.0f}MB" for (m, s), r in runs.items()),
              flush=True)
    stamp = provenance_line("bench_real_frames.py", started, (time.time() - t0) / 60.0,
                            (load0, os.getloadavg()[0]))
    text = markdown(results, solvers, stamp)
    print(text)
    if args.write:
        args.write.write_text(text)


if __name__ == "__main__":
    main()
