"""Peak memory of extract_centroids against the raw frame's size (16-bit frames up to 10000^2).

Each size runs in a fresh subprocess: a uint16 frame (sky 1000 counts, noise 20, a grid
of stars) is made in row blocks, the process's peak RSS is read (getrusage ru_maxrss),
the centroids are extracted, and the peak is read again. The growth of the peak over
the frame's raw size is what the extraction needs on top of the frame (compiled kernels
allocate outside Python, so tracemalloc would not see them).

    .venv/bin/python scripts/bench/bench_centroid_memory.py [--sizes 2048 4096 10000]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time

CHILD = """
import json, resource, sys, time
import numpy as np
from startrack.centroids._extract import extract_centroids
size = int(sys.argv[1])
rng = np.random.default_rng(size)
image = np.empty((size, size), np.uint16)
yy, xx = np.mgrid[-4:5, -4:5]
spot = 20000.0 * np.exp(-(xx**2 + yy**2) / 2.0)
for r in range(0, size, 256):  # row blocks: the frame is the only large allocation
    block = 1000.0 + rng.normal(0.0, 20.0, (min(256, size - r), size))
    for c in range(50, size - 50, 200):
        for rr in range(50 - r % 200, block.shape[0] - 5, 200):
            if rr >= 5:
                block[rr - 4:rr + 5, c - 4:c + 5] += spot
    image[r:r + block.shape[0]] = np.clip(block, 0, 65535)
    del block
extract_centroids(image[:512, :512])  # load the compiled kernels first
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
t0 = time.perf_counter()
found = extract_centroids(image)
seconds = time.perf_counter() - t0
after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
print(json.dumps({"raw": image.nbytes, "before": before, "after": after,
                  "seconds": seconds, "found": len(found)}))
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[2048, 4096, 10000])
    args = parser.parse_args()
    print(f"{'frame':>13} {'raw MB':>8} {'peak before MB':>15} {'peak after MB':>14} "
          f"{'growth / raw':>13} {'seconds':>8} {'centroids':>9}")
    for size in args.sizes:
        t0 = time.perf_counter()
        out = subprocess.run([sys.executable, "-c", CHILD, str(size)], capture_output=True,
                             text=True, check=False)
        if out.returncode:
            print(f"{size}: child failed after {time.perf_counter() - t0:.0f} s: "
                  f"{out.stderr.strip().splitlines()[-1:]}")
            continue
        r = json.loads(out.stdout.strip().splitlines()[-1])
        mb = 2.0**20
        print(f"{size:>6}x{size:<6} {r['raw'] / mb:8.0f} {r['before'] / mb:15.0f} "
              f"{r['after'] / mb:14.0f} {(r['after'] - r['before']) / r['raw']:13.2f} "
              f"{r['seconds']:8.2f} {r['found']:9d}")


if __name__ == "__main__":
    main()
