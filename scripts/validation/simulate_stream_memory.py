"""Peak memory of a long `startrack simulate` sequence, stopped by a signal, and its
up-front disk check.

    python scripts/validation/simulate_stream_memory.py [--seconds 60] [--frames 1000000]
    [--signal INT]

1. `simulate --frames N --fps 10` with the default 1024 x 1024 camera: N frames of ~1 MB
   do not fit most disks, so the run is refused before frame 1 (the message is printed).
2. The same with a 128 x 128 camera file (so that N frames fit the disk): it runs for
   --seconds, then gets SIGINT (or SIGTERM); printed: the peak RSS (os.wait4), RSS after
   10 s and at the end (from /proc), frames written, truth.csv rows, leftover temporary
   files, exit code. Bounded memory: the RSS at the end is that at 10 s.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def _rss_mb(pid: int) -> float:
    with open(f"/proc/{pid}/status") as fh:
        for line in fh:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    return float("nan")


def _simulate(args: list[str], seconds: float, stop: signal.Signals) -> dict:
    t0 = time.perf_counter()
    with tempfile.TemporaryFile() as err:
        p = subprocess.Popen([sys.executable, "-m", "startrack", "simulate", *args],
                             stdout=subprocess.DEVNULL, stderr=err,
                             # a shell's background job ignores SIGINT; a user's does not
                             preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
        samples = {}
        while True:  # wait4, not poll: poll would reap the child and lose its usage
            pid, status, usage = os.wait4(p.pid, os.WNOHANG)
            if pid:
                break
            time.sleep(0.5)
            elapsed = time.perf_counter() - t0
            if "at_10s" not in samples and elapsed >= 10:
                samples["at_10s"] = _rss_mb(p.pid)
            if "at_end" not in samples and elapsed >= seconds:
                samples["at_end"] = _rss_mb(p.pid)
                p.send_signal(stop)
        p.returncode = os.waitstatus_to_exitcode(status)
        err.seek(0)
        lines = err.read().decode(errors="replace").strip().splitlines()
    return {"exit": os.waitstatus_to_exitcode(status), "peak_rss_mb": usage.ru_maxrss / 1024,
            "seconds": time.perf_counter() - t0, "stderr": lines, **samples}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--frames", type=int, default=1_000_000)
    parser.add_argument("--signal", choices=["INT", "TERM"], default="INT")
    opts = parser.parse_args()
    stop = signal.Signals[f"SIG{opts.signal}"]
    with tempfile.TemporaryDirectory(dir=".") as tmp:
        tmp = Path(tmp)
        big = _simulate(["--frames", str(opts.frames), "--fps", "10", "--out",
                         str(tmp / "big")], 120.0, stop)
        print(f"1024 x 1024, --frames {opts.frames}: exit {big['exit']}, "
              f"{big['seconds']:.1f} s; {big['stderr'][-1] if big['stderr'] else ''}")
        camera = tmp / "small.json"
        camera.write_text(json.dumps({"width": 128, "height": 128, "fov_deg": 10.0}))
        out = tmp / "small"
        run = _simulate(["--frames", str(opts.frames), "--fps", "10", "--rate", "0.5,0,0",
                         "--camera", str(camera), "--out", str(out)], opts.seconds, stop)
        pngs = len(list(out.glob("frame_*.png")))
        truth = out / "truth.csv"
        rows = len(truth.read_text().splitlines()) - 1 if truth.exists() else None
        temps = [p.name for p in out.iterdir() if p.name.startswith(".")]
        print(f"128 x 128, --frames {opts.frames} --fps 10, SIG{opts.signal} after "
              f"{opts.seconds:g} s: exit {run['exit']}, peak RSS {run['peak_rss_mb']:.0f} MB "
              f"(RSS at 10 s {run.get('at_10s', float('nan')):.0f} MB, at the end "
              f"{run.get('at_end', float('nan')):.0f} MB); {pngs} frames written, "
              f"truth.csv rows {rows}, temporary files left {len(temps)}")
        print(f"  last stderr line: {run['stderr'][-1] if run['stderr'] else ''}")


if __name__ == "__main__":
    main()
