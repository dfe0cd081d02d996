"""A real frame against its simulation: render the frame's camera preset at the frame's
solved attitude and compare the two by :mod:`startrack.bench._frame_stats`, each
quantity against its stated tolerance (:data:`TOLERANCES`; docs/simulation.md)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from startrack.bench._frame_stats import FrameStats, frame_stats
from startrack.simulate import SimConfig

#: the tetra3 real-sky camera's preset (configs/)
REALSKY_PRESET = "blackfly_s_imx265"
#: magnitude bins of the star counts (Hipparcos Hp)
MAG_EDGES = (-2.0, 5.0, 6.0, 6.5, 7.0, 7.5, 8.0, 9.0)


@dataclass(frozen=True)
class Tolerance:
    """How close the simulation must come: ``relative`` of the real value, or
    ``absolute`` in the quantity's unit, whichever is larger."""

    relative: float
    absolute: float

    def allows(self, real: float, sim: float) -> bool:
        return abs(sim - real) <= max(self.relative * abs(real), self.absolute)

    def __str__(self) -> str:
        parts = [f"{self.relative:.0%}" if self.relative else "", f"{self.absolute:g}"
                 if self.absolute else ""]
        return " or ".join(p for p in parts if p)


TOLERANCES = {
    "stars detected": Tolerance(0.35, 3.0),  # per magnitude bin
    "background mean ADU": Tolerance(0.10, 0.0),
    "background noise ADU": Tolerance(0.25, 0.0),
    "PSF FWHM px": Tolerance(0.25, 0.0),
    "saturated stars": Tolerance(0.0, 3.0),
}


@dataclass(frozen=True)
class Row:
    quantity: str
    real: float
    simulated: float
    tolerance: Tolerance

    @property
    def ok(self) -> bool:
        return self.tolerance.allows(self.real, self.simulated)


def render_like(config: SimConfig, rotation, catalog, seed: int = 0) -> np.ndarray:
    """The preset's frame of ``catalog`` at ``rotation`` (its sensor and effects)."""
    from startrack.simulate import catalog_bv, observe, render_frame

    rng = np.random.default_rng([seed, 0])
    scene = observe(catalog, config.camera, rotation, rng)
    bv = None
    if not config.effects.band.is_off:
        bv = np.where(scene.catalog_row >= 0, catalog_bv(catalog)[scene.catalog_row], np.nan)
    return render_frame(scene, config.camera, config.sensor, rng, effects=config.effects,
                        effects_rng=np.random.default_rng([seed, 0, 1]), bv=bv)


def compare_rows(real: FrameStats, sim: FrameStats) -> list[Row]:
    """Every compared quantity of a real frame and its simulation, with its tolerance."""
    rows = [Row(f"stars detected, Hp {b}", r, s, TOLERANCES["stars detected"])
            for b, r, s in zip(real.bins(), real.detected, sim.detected, strict=True)]
    rows += [Row("background mean ADU", real.background_mean, sim.background_mean,
                 TOLERANCES["background mean ADU"]),
             Row("background noise ADU", real.background_noise, sim.background_noise,
                 TOLERANCES["background noise ADU"]),
             Row("PSF FWHM px", real.fwhm_px, sim.fwhm_px, TOLERANCES["PSF FWHM px"]),
             Row("saturated stars", real.saturated_stars, sim.saturated_stars,
                 TOLERANCES["saturated stars"])]
    return rows


def night_sky(real_image: np.ndarray, config: SimConfig) -> SimConfig:
    """``config`` with the sky glow of ``real_image``: the median of its central tenth
    (radius), bias and dark current removed. The one number a ground frame's night
    sets rather than its camera; everything else stays the preset's."""
    h, w = real_image.shape
    rows, cols = np.ogrid[:h, :w]
    centre = np.hypot(rows - (h - 1) / 2, cols - (w - 1) / 2) < 0.05 * np.hypot(h, w)
    s = config.sensor
    level = (float(np.median(real_image[centre])) - s.bias_adu) * s.gain / s.exposure_s
    sky = max(level - s.dark_current, 0.0)
    return dataclasses.replace(config, sensor=dataclasses.replace(s, sky_background=sky))


def check_frame(real_image: np.ndarray, config: SimConfig, rotation, catalog,
                seed: int = 0) -> tuple[np.ndarray, list[Row]]:
    """The simulated frame (with the real frame's :func:`night_sky`) and the comparison
    rows of ``real_image`` seen at ``rotation``."""
    config = night_sky(real_image, config)
    sim = render_like(config, rotation, catalog, seed)
    adc = config.sensor.adc_max
    stats = [frame_stats(img, config.camera, rotation, catalog, MAG_EDGES, adc)
             for img in (real_image, sim)]
    return sim, compare_rows(*stats)

__all__ = ["MAG_EDGES", "REALSKY_PRESET", "Row", "TOLERANCES", "Tolerance", "check_frame",
           "compare_rows", "night_sky", "render_like"]
