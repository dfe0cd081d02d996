"""How flat the centroider's sky model leaves the real frames' sky glow (median residuals).

For each real frame of ../shared/real-sky (sky glow and vignetting from ~1,900 to 7,500
counts), the sky model that ``extract_centroids`` detects against is taken (caught at
its call of the components pass), the frame minus it is cut into boxes of ``--box`` px
(laid half a tile off the model's tiles), and each box's median residual is measured over
the pixels that are not sources (3 noise sigmas, grown by 2 px). A perfect model leaves
only the boxes' own noise; what is printed is the mean, RMS and largest of the box
medians, in noise sigmas, and the box-median noise floor for comparison.

    PYTHONPATH=. .venv/bin/python scripts/bench/bench_centroid_sky.py [--box 32]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from scipy.ndimage import binary_dilation

from startrack.centroids import _extract as extract
from startrack.io import read_image

REAL_SKY = Path(__file__).resolve().parents[3].parent / "shared" / "real-sky"


def sky_model(image: np.ndarray, config=None) -> np.ndarray:
    """The background image ``extract_centroids`` detects against."""
    caught = {}
    components = extract._components

    def spy(frame, model, *args):
        caught["model"] = model
        return components(frame, model, *args)

    extract._components = spy
    try:
        extract.extract_centroids(image, config)
    finally:
        extract._components = components
    return caught["model"].image()


def box_medians(resid: np.ndarray, keep: np.ndarray, box: int, offset: int) -> np.ndarray:
    h, w = resid.shape
    out = []
    for r in range(offset, h - box + 1, box):
        for c in range(offset, w - box + 1, box):
            k = keep[r:r + box, c:c + box]
            if k.sum() > box * box // 2:
                out.append(np.median(resid[r:r + box, c:c + box][k]))
    return np.array(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--box", type=int, default=32)
    parser.add_argument("--fast", action="store_true", help="CentroidConfig(fast=True)")
    args = parser.parse_args()
    folder = REAL_SKY if REAL_SKY.is_dir() else Path("/work/shared/real-sky")
    config = extract.CentroidConfig(fast=args.fast)
    print(f"sky model of extract_centroids ({extract.__file__}), fast={args.fast}; "
          f"box medians of the residual in noise sigmas, {args.box} px boxes")
    print(f"{'frame':>10} {'boxes':>6} {'mean':>7} {'RMS':>7} {'max |.|':>8} {'floor':>7}")
    for path in sorted(folder.glob("*.tiff")):
        image = read_image(path)
        resid = image.astype(np.float64) - sky_model(image, config)
        sigma = 1.4826 * np.median(np.abs(resid - np.median(resid)))
        keep = ~binary_dilation(resid > 3 * sigma, iterations=2)
        med = box_medians(resid, keep, args.box, config.background_size // 2) / sigma
        floor = 1.2533 / args.box  # a median's noise over box^2 pixels, in sigmas
        print(f"{path.stem.split('_')[2]:>10} {len(med):>6} {med.mean():>7.3f} "
              f"{np.sqrt(np.mean(med**2)):>7.3f} {np.abs(med).max():>8.3f} {floor:>7.3f}")


if __name__ == "__main__":
    main()
