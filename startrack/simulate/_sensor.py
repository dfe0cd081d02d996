"""The optics and detector of a star tracker: magnitudes to electrons, electrons to counts."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields

import numpy as np

from startrack.errors import InputError
from startrack.input_checks import check_table


@dataclass(frozen=True)
class SensorModel:
    """Photometric and detector parameters; the defaults are a generic small star tracker.

    Units: photons, electrons (e-), ADU (counts), seconds, pixels.
    """

    # Photons/s/cm^2 from a magnitude-0 star over a broad visible band: the V-band zero
    # point (Bessell 1998: 3.6e-9 erg/s/cm^2/A at 550 nm, ~1000 photons/s/cm^2/A) times
    # ~1000 A of effective bandwidth of an unfiltered silicon detector.
    zero_point: float = 1.0e6
    # Entrance pupil: 25 mm is typical of small star-tracker lenses (f ~ 25-50 mm, f/1-f/2).
    aperture_mm: float = 25.0
    # Lens and window throughput (several AR-coated elements).
    transmission: float = 0.8
    # Band-averaged quantum efficiency of a front-illuminated CMOS/CCD over 400-900 nm.
    quantum_efficiency: float = 0.6
    # Star trackers integrate 50-250 ms; 100 ms is a common default.
    exposure_s: float = 0.1
    # Star trackers defocus slightly so a star spreads over ~3x3 to 5x5 pixels, which is
    # what makes sub-pixel centroiding possible; sigma = 1 px gives that.
    psf_sigma_px: float = 1.0
    # False "blob" stars (planets out of focus, debris, glints) are this much wider.
    blob_sigma_factor: float = 2.5
    # Zodiacal light in orbit is ~22.5 mag/arcsec^2; with the defaults above and ~60"
    # pixels that is ~10 e-/px/s.
    sky_background: float = 10.0
    # Uncooled CMOS near room temperature: ~10-50 e-/px/s.
    dark_current: float = 20.0
    # Read noise of a typical scientific/industrial CMOS or CCD readout.
    read_noise: float = 10.0
    # Gain chosen so the 16-bit ADC saturates just below full well, as in many CMOS
    # cameras (saturated stars read as the ADC maximum, like the real frames' 65535).
    gain: float = 0.45
    full_well: float = 30000.0
    adc_bits: int = 16
    # Bias keeps the read noise around a dark pixel (~22 ADU rms here) from clipping at 0.
    bias_adu: float = 200.0

    def __post_init__(self) -> None:
        positive = ("zero_point", "aperture_mm", "transmission", "quantum_efficiency",
                    "exposure_s", "psf_sigma_px", "blob_sigma_factor", "gain", "full_well")
        for name in positive:
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise InputError(f"sensor: {name} must be a positive number, got {value!r}")
        for name in ("sky_background", "dark_current", "read_noise", "bias_adu"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value >= 0):
                raise InputError(f"sensor: {name} must be a number >= 0, got {value!r}")
        if self.transmission > 1 or self.quantum_efficiency > 1:
            raise InputError("sensor: transmission and quantum_efficiency must be <= 1")
        if not isinstance(self.adc_bits, int) or not 8 <= self.adc_bits <= 16:
            raise InputError(f"sensor: adc_bits must be an integer in 8..16, got "
                             f"{self.adc_bits!r}")

    @property
    def adc_max(self) -> int:
        return 2**self.adc_bits - 1

    @property
    def aperture_area_cm2(self) -> float:
        return math.pi * (self.aperture_mm / 20.0) ** 2

    @property
    def electrons_mag0(self) -> float:
        """Electrons collected in one exposure from a magnitude-0 star."""
        return (self.zero_point * self.aperture_area_cm2 * self.transmission
                * self.quantum_efficiency * self.exposure_s)

    @property
    def background_electrons(self) -> float:
        """Expected sky + dark electrons per pixel in one exposure."""
        return (self.sky_background + self.dark_current) * self.exposure_s

    def electrons_from_mag(self, mag: np.ndarray | float) -> np.ndarray:
        """Expected electrons in one exposure for stars of magnitude ``mag``."""
        return self.electrons_mag0 * 10.0 ** (-0.4 * np.asarray(mag, dtype=np.float64))

    def to_dict(self) -> dict:
        return asdict(self)


SENSOR_KEYS = frozenset(f.name for f in fields(SensorModel))


def sensor_from_dict(data: dict, where: str = "sensor") -> SensorModel:
    """A sensor from a table of SensorModel fields; unknown keys are errors."""
    check_table(data, SENSOR_KEYS, where, "sensor")
    try:
        return SensorModel(**data)
    except InputError as exc:
        raise InputError(f"{where}: {str(exc).removeprefix('sensor: ')}") from None
