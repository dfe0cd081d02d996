"""Score `startrack identify --format json` output against a `startrack simulate` truth.csv:
solved count, pointings more than 60 arcsec off (wrong), worst error, fitted FOVs.

    startrack simulate --camera cam.json --sky gaia --mag-limit 10 --frames 8 --out sim
    mkdir bare && cp sim/*.png bare/            # no sidecars: nothing tells the FOV
    startrack identify bare/*.png --format json > ids.json           # no FOV at all
    startrack identify bare/*.png --fov 3.12 --format json > ids4.json   # 4 % off
    python scripts/validation/check_simulated.py sim/truth.csv ids.json
"""

from __future__ import annotations

import csv
import json
import math
import sys
from pathlib import Path

import numpy as np

from startrack.sky import radec_to_vectors

WRONG_ARCSEC = 60.0


def main(truth_path: str, ids_path: str) -> None:
    with open(truth_path, newline="") as fh:
        truth = {row["file"]: row for row in csv.DictReader(fh)}
    with open(ids_path) as fh:
        records = [json.loads(line) for line in fh if line.strip()]
    solved = wrong = total = 0
    worst, fovs, times = 0.0, [], []
    for rec in records:
        total += 1
        times.append(rec.get("timing_ms", {}).get("identify", float("nan")))
        if rec["status"] != "solved":
            continue
        solved += 1
        t = truth[Path(rec["input"]).name]
        a = radec_to_vectors(np.array([rec["attitude"]["ra_deg"]]),
                             np.array([rec["attitude"]["dec_deg"]]))[0]
        b = radec_to_vectors(np.array([float(t["ra_deg"])]), np.array([float(t["dec_deg"])]))[0]
        err = math.degrees(math.acos(min(1.0, float(a @ b)))) * 3600.0
        worst = max(worst, err)
        wrong += err > WRONG_ARCSEC
        fovs.append(rec.get("fov_deg", float("nan")))
    fov_text = (f"fitted FOV {min(fovs):.4f} to {max(fovs):.4f} deg" if fovs else "no FOV")
    print(f"{ids_path}: solved {solved}/{total}, wrong {wrong}, worst pointing error "
          f"{worst:.1f} arcsec, {fov_text}, median identify {np.nanmedian(times):.0f} ms")


if __name__ == "__main__":
    main(*sys.argv[1:3])
