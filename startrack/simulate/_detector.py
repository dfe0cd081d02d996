"""The detector beyond the sensor's read-out chain: dark current with temperature, fixed
pattern noise (PRNU, DSNU), blooming, rolling shutter and ADC non-linearity.

* Dark current doubles every ``dark_doubling_c`` degrees (the silicon rule of thumb: about
  5.5 to 7 C for CCDs and CMOS): the sensor's ``dark_current`` holds at ``reference_c``.
* PRNU (photo-response non-uniformity) multiplies the photo-signal of each pixel by
  ``1 + prnu * N(0, 1)``; DSNU (dark-signal non-uniformity) multiplies its dark current by
  ``max(0, 1 + dsnu * N(0, 1))``. Both maps are fixed by ``map_seed``: one sensor, every frame.
* Blooming: charge above the full well spills along its column, half up, half down,
  filling the neighbours to full well in turn (``blooming``).
* Rolling shutter: row ``r`` is exposed ``(r / (H - 1) - 0.5) * readout_s`` after the frame's
  mid-time, so a turning camera shears the stars (``readout_s``: top to bottom read time).
* ADC non-linearity: ``e -> e * (1 - adc_nonlinearity * e / full_well)``, a compression that
  reaches ``adc_nonlinearity`` at full well.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from startrack.input_checks import Bounds
from startrack.simulate._effect_table import changed, number

#: the temperature at which a sensor's ``dark_current`` is given, C
REFERENCE_C = 20.0


@dataclass(frozen=True)
class Detector:
    """Detector effects; every default leaves today's frames as they are."""

    temperature_c: float = number(REFERENCE_C, Bounds(-100.0, 150.0), "detector temperature, C")
    reference_c: float = number(REFERENCE_C, Bounds(-100.0, 150.0),
                                "temperature of the sensor's dark_current, C")
    dark_doubling_c: float = number(6.0, Bounds(1.0, 30.0), "dark current doubles every, C")
    prnu: float = number(0.0, Bounds(0.0, 0.5), "photo-response non-uniformity, rms fraction")
    dsnu: float = number(0.0, Bounds(0.0, 5.0), "dark-signal non-uniformity, rms fraction")
    map_seed: float = number(0, Bounds(0, 2**31 - 1, integer=True), "seed of the PRNU/DSNU maps")
    blooming: bool = False
    readout_s: float = number(0.0, Bounds(0.0, 10.0), "rolling shutter read time, s")
    adc_nonlinearity: float = number(0.0, Bounds(0.0, 0.5), "compression at full well")

    @property
    def is_off(self) -> bool:
        return not changed(self)

    def dark_factor(self) -> float:
        """Dark current at ``temperature_c`` over that at ``reference_c`` (exactly 1 there)."""
        if self.temperature_c == self.reference_c:
            return 1.0
        return 2.0 ** ((self.temperature_c - self.reference_c) / self.dark_doubling_c)

    def prnu_map(self, shape: tuple[int, int]) -> np.ndarray | None:
        """Per-pixel photo-response (mean 1), None without PRNU."""
        return None if self.prnu == 0 else _pattern(shape, int(self.map_seed), 0, self.prnu)

    def dsnu_map(self, shape: tuple[int, int]) -> np.ndarray | None:
        """Per-pixel dark-current factor (mean about 1, never negative), None without DSNU."""
        return None if self.dsnu == 0 else _pattern(shape, int(self.map_seed), 1, self.dsnu)

    def row_times(self, y: np.ndarray, height: int) -> np.ndarray:
        """When row ``y`` is exposed relative to the frame's mid-time, s."""
        if self.readout_s == 0 or height < 2:
            return np.zeros(np.shape(y))
        return (np.asarray(y) / (height - 1) - 0.5) * self.readout_s


@lru_cache(maxsize=4)
def _pattern(shape: tuple[int, int], seed: int, which: int, rms: float) -> np.ndarray:
    """A fixed pattern map ``max(0, 1 + rms * N(0, 1))`` (float32), one per (seed, which)."""
    rng = np.random.default_rng([seed, 7919, which])
    out = rng.standard_normal(shape, dtype=np.float32)
    out *= np.float32(rms)
    out += np.float32(1.0)
    np.maximum(out, 0.0, out=out)
    out.setflags(write=False)
    return out

__all__ = ["Detector", "REFERENCE_C"]
