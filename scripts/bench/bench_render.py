"""Time the frame renderer: ms per frame at 1024^2 and 4096^2 with ~100 stars.

Run: .venv/bin/python scripts/bench/bench_render.py [--repeats N]
Prints the median over N renders of the whole frame (render_frame) and of its two
parts: the star spots alone (render_stars) and the per-pixel noise and ADC (digitise);
wall-clock and, in brackets, this process's CPU time (what other load on a shared
machine does not inflate).
"""

from __future__ import annotations

import numpy as np

from scripts._cli import add_repeats, script_parser
from scripts.bench._timing import wall_cpu_ms
from startrack.attitude import from_radec_roll
from startrack.camera import Camera
from startrack.simulate import (
    Scene,
    SensorModel,
    digitise,
    render_expected,
    render_frame,
    render_stars,
)


def synthetic_scene(camera: Camera, n: int, rng: np.random.Generator) -> Scene:
    """``n`` real-looking stars at random positions, magnitudes 1..7."""
    return Scene(
        x=rng.uniform(0, camera.width - 1, n), y=rng.uniform(0, camera.height - 1, n),
        mag=rng.uniform(1.0, 7.0, n), catalog_id=np.arange(n), catalog_row=np.arange(n),
        is_false=np.zeros(n, bool), hot_pixel=np.zeros(n, bool),
        rotation=from_radec_roll(0.0, 0.0, 0.0))


def median_ms(fn, repeats: int) -> str:
    """Median wall and CPU ms of ``fn``, as "wall (cpu)"."""
    wall, cpu = wall_cpu_ms(fn, repeats)
    return f"{wall:.1f} ({cpu:.1f})"


def main() -> None:
    parser = script_parser(__doc__)
    add_repeats(parser, 7)
    parser.add_argument("--stars", type=int, default=100)
    args = parser.parse_args()
    sensor = SensorModel()
    rng = np.random.default_rng(0)
    print(f"render benchmark: {args.stars} stars, median of {args.repeats} runs, "
          f"numpy {np.__version__}")
    print(f"{'frame':>11} {'total ms':>15} {'stars ms':>15} {'blur8 ms':>15} "
          f"{'noise+ADC ms':>15}")
    for size in (1024, 4096):
        camera = Camera.from_fov(size, size, 17.5)
        scene = synthetic_scene(camera, args.stars, rng)
        expected = render_expected(scene, camera, sensor)
        total = median_ms(lambda: render_frame(scene, camera, sensor, rng), args.repeats)  # noqa: B023
        stars = median_ms(lambda: render_stars(scene, camera, sensor), args.repeats)  # noqa: B023
        blur = median_ms(lambda: render_stars(scene, camera, sensor,  # noqa: B023
                                              angular_rate_dps=(0.5, 0.5, 1.0)), args.repeats)
        noise = median_ms(lambda: digitise(expected, sensor, rng), args.repeats)  # noqa: B023
        print(f"{size:>5}x{size:<5} {total:>15} {stars:>15} {blur:>15} {noise:>15}")
    print("noise+ADC: the sky pixels draw from one exact table of their read-out value;"
          " the star pixels go through the chain pixel by pixel.")


if __name__ == "__main__":
    main()
