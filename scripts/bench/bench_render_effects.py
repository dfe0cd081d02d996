"""Time a 2048 x 2048 frame with every simulator effect on against today's default render.

Run: .venv/bin/python scripts/bench/bench_render_effects.py [--repeats N] [--stars N]

Both renders draw the same ~100-star scene turning at 0.5 deg/s (motion blur in both;
the rolling shutter needs the turn). "Every effect": a field-varying defocused PSF
(astigmatism and coma), cos^4 vignetting, tangential distortion, a silicon QE band with
star colours, dark current at 40 C, PRNU and DSNU, blooming, a rolling shutter, ADC
non-linearity, cosmic rays at the South Atlantic Anomaly's flux, stray light and the Moon
in the field. Prints the median wall and CPU ms of each, their ratio (the issue's bound:
at most 3), the commit and the machine's load (uptime): a loaded machine inflates wall
time, so the CPU ratio is the figure to quote.
"""

from __future__ import annotations

import os
import subprocess

import numpy as np

from scripts._cli import add_repeats, script_parser
from scripts.bench._timing import wall_cpu_ms
from scripts.bench.bench_render import synthetic_scene
from startrack.camera import Camera
from startrack.simulate import (
    SAA_FLUX,
    Band,
    Detector,
    Effects,
    Environment,
    Optics,
    SensorModel,
    render_frame,
)

RATE = (0.5, 0.2, 0.1)
EVERY_EFFECT = Effects(
    optics=Optics(psf="defocus", defocus_radius_px=1.5, astigmatism=0.5, coma_px=1.0,
                  vignetting="cos4", p1=1e-4, p2=-1e-4),
    band=Band(qe_nm=(350.0, 500.0, 700.0, 900.0, 1050.0), qe_value=(0.1, 0.5, 0.7, 0.4, 0.05)),
    detector=Detector(temperature_c=40.0, prnu=0.01, dsnu=0.3, blooming=True, readout_s=0.03,
                      adc_nonlinearity=0.02),
    environment=Environment(cosmic_rays=SAA_FLUX, stray_light=50.0, stray_gradient=2.0,
                            body_mag=-12.7, body_radius_deg=0.26, body_x=300.0, body_y=400.0),
)


def main() -> None:
    parser = script_parser(__doc__)
    add_repeats(parser, 7)
    parser.add_argument("--stars", type=int, default=100)
    parser.add_argument("--size", type=int, default=2048)
    args = parser.parse_args()
    camera = Camera.from_fov(args.size, args.size, 17.5)
    sensor = SensorModel()
    scene = synthetic_scene(camera, args.stars, np.random.default_rng(0))
    bv = np.random.default_rng(1).uniform(-0.2, 1.8, args.stars)
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True, check=False).stdout.strip() or "unknown"

    def plain():
        render_frame(scene, camera, sensor, np.random.default_rng(2), angular_rate_dps=RATE)

    def everything():
        render_frame(scene, camera, sensor, np.random.default_rng(2), angular_rate_dps=RATE,
                     effects=EVERY_EFFECT, effects_rng=np.random.default_rng(3), bv=bv)

    base, full = wall_cpu_ms(plain, args.repeats), wall_cpu_ms(everything, args.repeats)
    print(f"render {args.size}x{args.size}, {args.stars} stars, rate {RATE} deg/s, median of "
          f"{args.repeats}; commit {commit}; load average {os.getloadavg()[0]:.2f} on "
          f"{os.cpu_count()} CPUs")
    print(f"{'render':<16} {'wall ms':>9} {'cpu ms':>9}")
    print(f"{'default':<16} {base[0]:>9.1f} {base[1]:>9.1f}")
    print(f"{'every effect':<16} {full[0]:>9.1f} {full[1]:>9.1f}")
    print(f"ratio (every effect / default): wall {full[0] / base[0]:.2f}, "
          f"cpu {full[1] / base[1]:.2f} (bound: 3)")


if __name__ == "__main__":
    main()
