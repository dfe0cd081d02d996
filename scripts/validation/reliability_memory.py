"""Peak memory (max RSS) and wall time of `startrack identify` on the issue-10 inputs that
had no guard: a 200k-row centroid CSV, a 20000 x 20000 PNG, `--mag-limit 20` (Hipparcos),
each beside an ordinary frame for scale.

    python scripts/validation/reliability_memory.py

Each case runs as its own process (os.wait4 gives that process's own peak); the cache
is a fresh temporary folder except for a warm-up run, so database builds are not timed.
"""

from __future__ import annotations

import json
import os
import struct
import subprocess
import sys
import tempfile
import time
import zlib
from pathlib import Path

import numpy as np

CAMERA = {"width": 1024, "height": 1024, "fov_deg": 17.5}


def _measure(args: list[str], env: dict) -> tuple[int, float, float, str]:
    """(exit code, peak RSS in MB, seconds, last stderr line) of one startrack process."""
    t0 = time.perf_counter()
    with tempfile.TemporaryFile() as err:
        p = subprocess.Popen([sys.executable, "-m", "startrack", *args], env=env,
                             stdout=subprocess.DEVNULL, stderr=err)
        _, status, usage = os.wait4(p.pid, 0)
        p.returncode = os.waitstatus_to_exitcode(status)
        err.seek(0)
        lines = err.read().decode(errors="replace").strip().splitlines()
    return (p.returncode, usage.ru_maxrss / 1024.0, time.perf_counter() - t0,
            lines[-1] if lines else "")


def _huge_png(path: Path, side: int) -> None:
    """A valid 8-bit grey PNG of side x side black pixels, streamed (never in memory)."""
    def chunk(kind: bytes, data: bytes) -> bytes:
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data)))

    comp = zlib.compressobj(9)
    row = b"\0" * (side + 1)  # filter byte + pixels
    with open(path, "wb") as fh:
        fh.write(b"\x89PNG\r\n\x1a\n")
        fh.write(chunk(b"IHDR", struct.pack(">IIBBBBB", side, side, 8, 0, 0, 0, 0)))
        data = b"".join(comp.compress(row) for _ in range(side)) + comp.flush()
        fh.write(chunk(b"IDAT", data))
        fh.write(chunk(b"IEND", b""))


def _csv(path: Path, n: int, rng: np.random.Generator) -> None:
    xy = rng.uniform(0, 1023, (n, 2))
    flux = rng.uniform(1, 1000, n)
    with open(path, "w") as fh:
        fh.write("x,y,flux\n")
        np.savetxt(fh, np.column_stack([xy, flux]), fmt="%.3f", delimiter=",")


def main() -> None:
    rng = np.random.default_rng(0)
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        env = {**os.environ, "STARTRACK_CACHE_DIR": str(tmp / "cache")}
        cam = tmp / "cam.json"
        cam.write_text(json.dumps(CAMERA))
        _csv(tmp / "small.csv", 30, rng)
        _csv(tmp / "big.csv", 200_000, rng)
        _huge_png(tmp / "huge.png", 20000)
        base = ["identify", "--camera", str(cam), "--sky", "random"]
        _measure([*base, str(tmp / "small.csv")], env)  # warm the database cache
        cases = [
            ("30-row CSV (scale)", [*base, str(tmp / "small.csv")]),
            ("200k-row CSV", [*base, str(tmp / "big.csv")]),
            ("20000^2 PNG", ["identify", "--fov", "10", str(tmp / "huge.png")]),
            ("--mag-limit 20 hipparcos", ["identify", "--camera", str(cam), "--sky",
                                          "hipparcos", "--mag-limit", "20",
                                          str(tmp / "small.csv")]),
        ]
        print(f"{'case':<28} {'exit':>4} {'peak MB':>8} {'s':>6}  stderr (last line)")
        for name, args in cases:
            code, mb, sec, line = _measure(args, env)
            print(f"{name:<28} {code:>4} {mb:8.0f} {sec:6.1f}  {line[:110]}")


if __name__ == "__main__":
    main()
