"""Time startrack's extract_centroids beside tetra3rs's on the same pixels, and compare lists.

Image sets: the four real frames of ../shared/real-sky (1024 x 768, 16-bit, sky glow,
hot pixels, saturated stars) and rendered 1024^2 and 4096^2 frames (startrack.simulate._render,
default SensorModel, a random sky to magnitude 8 seen at 20 deg, seeded). Each repeat
times every extractor once on the same array, in turn, so that load on the machine hits
all of them alike; the table gives medians and the ratio ours / tetra3rs.

Both are timed with their defaults (startrack: a thread per core the process may use,
fewer when the machine is busy; tetra3rs: every core) and on one thread
(CentroidConfig(threads=1), tetra3rs threads=1). Agreement: of the tetra3rs centroids,
how many have one of ours within 1 px, and the other way round (tetra3rs's origin is the
image centre, (W-1)/2). On rendered frames both are scored against the truth: stars
found within 1.5 px and the RMS position error of those of signal above 3000 e- (where
both should be near the photon limit).

    PYTHONPATH=. /work/peers-venv/bin/python scripts/bench/bench_centroid_peers.py [--repeats 15]
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from scripts._cli import add_repeats, script_parser
from startrack.attitude import random_attitudes
from startrack.camera import Camera
from startrack.centroids import FAST, CentroidConfig, extract_centroids
from startrack.io import read_image
from startrack.simulate import SensorModel, observe, render_frame
from startrack.sky import random_sky

REAL_SKY = Path(__file__).resolve().parents[3].parent / "shared" / "real-sky"
AGREE_PX = 1.0
MATCH_PX = 1.5
ONE_THREAD = CentroidConfig(threads=1)


def real_frames() -> dict[str, np.ndarray]:
    folder = REAL_SKY if REAL_SKY.is_dir() else Path("/work/shared/real-sky")
    return {p.stem.split("_")[2]: read_image(p) for p in sorted(folder.glob("*.tiff"))}


def rendered(size: int, seed: int):
    """A rendered frame and its scene (true positions and electrons)."""
    rng = np.random.default_rng(seed)
    camera = Camera.from_fov(size, size, 20.0)
    sensor = SensorModel()
    catalog = random_sky(n_stars=40000, seed=seed, mag_max=8.0)
    scene = observe(catalog, camera, random_attitudes(1, rng)[0], rng)
    return render_frame(scene, camera, sensor, rng), scene, sensor


def extractors():
    import tetra3rs

    def t3(image, **kw):
        h, w = image.shape
        found = tetra3rs.extract_centroids(image, **kw).centroids
        return np.array([[c.x + (w - 1) / 2, c.y + (h - 1) / 2] for c in found]).reshape(-1, 2)

    def t3fast(image, **kw):
        h, w = image.shape
        found = tetra3rs.extract_centroids_fast(image, **kw).centroids
        return np.array([[c.x + (w - 1) / 2, c.y + (h - 1) / 2] for c in found]).reshape(-1, 2)

    def ours(image, config=None):
        found = extract_centroids(image, config)
        return np.c_[found.x, found.y]

    return {"startrack": ours, "startrack fast": lambda im: ours(im, FAST),
            "startrack 1 thread": lambda im: ours(im, ONE_THREAD),
            "tetra3rs": t3, "tetra3rs 1 thread": lambda im: t3(im, threads=1),
            "tetra3rs fast": t3fast, "tetra3rs fast 1 thread": lambda im: t3fast(im, threads=1)}


def time_all(image: np.ndarray, funcs: dict, repeats: int) -> tuple[dict, dict]:
    out = {name: f(image) for name, f in funcs.items()}  # warm-up, and the lists
    times = {name: [] for name in funcs}
    for _ in range(repeats):
        for name, f in funcs.items():
            t0 = time.perf_counter()
            f(image)
            times[name].append(time.perf_counter() - t0)
    return {k: 1e3 * float(np.median(v)) for k, v in times.items()}, out


def within(a: np.ndarray, b: np.ndarray, tol: float) -> int:
    """How many points of ``a`` have a point of ``b`` within ``tol`` px."""
    if len(a) == 0 or len(b) == 0:
        return 0
    return int(np.count_nonzero(cKDTree(b).query(a)[0] < tol))


def truth_score(found: np.ndarray, scene, sensor) -> str:
    bright = sensor.electrons_from_mag(scene.mag) > 3000
    truth = np.c_[scene.x, scene.y]
    if len(found) == 0:
        return "found 0"
    d, j = cKDTree(found).query(truth)
    hit = d < MATCH_PX
    err = d[hit & bright]
    return f"found {hit.mean():6.1%} of {len(truth)}, RMS {np.sqrt(np.mean(err**2)):.3f} px"


def main() -> None:
    parser = script_parser(__doc__)
    add_repeats(parser, 15)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    funcs = extractors()
    sets = {f"real {k}": (im, None) for k, im in real_frames().items()}
    for size in (1024, 4096):
        image, scene, sensor = rendered(size, args.seed + size)
        sets[f"rendered {size}^2"] = (image, (scene, sensor))
    print(f"median ms over {args.repeats} repeats (each repeat: every extractor once, in turn)")
    print(f"{'image':>18} " + " ".join(f"{n:>14}" for n in funcs)
          + "  ours/t3rs  1 thread: ours/t3rs")
    real_ms = {n: [] for n in funcs}
    for name, (image, truth) in sets.items():
        ms, lists = time_all(image, funcs, args.repeats if image.size < 4e6 else 5)
        for n in funcs:
            if name.startswith("real"):
                real_ms[n].append(ms[n])
        print(f"{name:>18} " + " ".join(f"{ms[n]:14.2f}" for n in funcs)
              + f"  {ms['startrack'] / ms['tetra3rs']:9.2f}"
              f"  {ms['startrack 1 thread'] / ms['tetra3rs 1 thread']:19.2f}")
        ours, theirs = lists["startrack"], lists["tetra3rs"]
        print(f"{'':>18} centroids: ours {len(ours)}, tetra3rs {len(theirs)}; tetra3rs with "
              f"ours within {AGREE_PX:g} px: {within(theirs, ours, AGREE_PX)}, ours with "
              f"tetra3rs's: {within(ours, theirs, AGREE_PX)}")
        if truth is not None:
            for n in ("startrack", "startrack fast", "tetra3rs", "tetra3rs fast"):
                print(f"{'':>18} {n:>14}: {truth_score(lists[n], *truth)}")
    med = {n: float(np.median(v)) for n, v in real_ms.items()}
    print(f"{'real, median':>18} " + " ".join(f"{med[n]:14.2f}" for n in funcs)
          + f"  {med['startrack'] / med['tetra3rs']:9.2f}"
          f"  {med['startrack 1 thread'] / med['tetra3rs 1 thread']:19.2f}")


if __name__ == "__main__":
    main()
