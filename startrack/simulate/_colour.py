"""Star colour through the tracker's band: red and blue stars of one magnitude give
different signals.

A star's catalog colour (Hipparcos B-V, or Gaia BP-RP through :func:`bv_from_bp_rp`) gives
its effective temperature (Ballesteros 2012, EPL 97 34008:
``T = 4600 K (1 / (0.92 (B-V) + 1.7) + 1 / (0.92 (B-V) + 0.62))``); its photon spectrum is
taken as a black body at that temperature, normalised to the catalog magnitude in the V
band (Bessell's V as a Gaussian at 551 nm, 88 nm FWHM), and counted through the tracker's
filter transmission and detector QE curves. The sensor's ``quantum_efficiency`` stays the
band average for a star of :data:`REFERENCE_BV` (a Sun-like star): the colour factor is the
ratio of a star's electrons to such a star's of the same magnitude. Stars without a colour
(random skies, catalogs without one) take :data:`REFERENCE_BV`, i.e. a factor of 1.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from startrack.simulate._effect_table import changed, curve

REFERENCE_BV = 0.65
_WAVELENGTH_NM = np.linspace(300.0, 1100.0, 401)
_H_C_OVER_K_NM = 1.4387769e7  # h c / k_B in nm K


@dataclass(frozen=True)
class Band:
    """The tracker's spectral response: filter and QE curves over wavelength (nm). An
    empty curve is flat; with both empty, colour has no effect (the default)."""

    filter_nm: tuple[float, ...] = curve("filter curve wavelengths, nm")
    filter_value: tuple[float, ...] = curve("filter transmission at filter_nm, 0..1")
    qe_nm: tuple[float, ...] = curve("QE curve wavelengths, nm")
    qe_value: tuple[float, ...] = curve("quantum efficiency at qe_nm, 0..1")

    def __post_init__(self) -> None:
        for nm, value, name in ((self.filter_nm, self.filter_value, "filter"),
                                (self.qe_nm, self.qe_value, "qe")):
            if len(nm) != len(value) or (nm and len(nm) < 2):
                raise ValueError(f"{name}_nm and {name}_value must be lists of one length, "
                                 "at least 2")
            if nm and (np.any(np.diff(nm) <= 0) or min(value) < 0 or max(value) > 1):
                raise ValueError(f"{name}_nm must increase and {name}_value lie in [0, 1]")

    @property
    def is_off(self) -> bool:
        return not changed(self)

    def response(self) -> np.ndarray:
        """Filter x QE on the integration grid (outside a curve: 0)."""
        out = np.ones_like(_WAVELENGTH_NM)
        for nm, value in ((self.filter_nm, self.filter_value), (self.qe_nm, self.qe_value)):
            if nm:
                out = out * np.interp(_WAVELENGTH_NM, nm, value, left=0.0, right=0.0)
        return out

    def colour_factor(self, bv: np.ndarray) -> np.ndarray:
        """Electrons of stars of colour ``bv`` over those of a :data:`REFERENCE_BV` star of
        the same V magnitude (1 where ``bv`` is NaN, or the band is off)."""
        bv = np.asarray(bv, dtype=np.float64)
        if self.is_off:
            return np.ones(bv.shape)
        known = np.isfinite(bv)
        grid = np.linspace(-0.4, 2.5, 146)
        table = _factors(self, tuple(grid))
        out = np.ones(bv.shape)
        out[known] = np.interp(np.clip(bv[known], grid[0], grid[-1]), grid, table)
        return out


def temperature_from_bv(bv) -> np.ndarray:
    """Effective temperature (K) of a star of colour B-V (Ballesteros 2012)."""
    bv = np.asarray(bv, dtype=np.float64)
    return 4600.0 * (1.0 / (0.92 * bv + 1.7) + 1.0 / (0.92 * bv + 0.62))


def temperature_from_bp_rp(bp_rp) -> np.ndarray:
    """Effective temperature (K) of a star of Gaia colour BP-RP: Mucciarelli, Bellazzini &
    Massari 2021 (A&A 653, A90), Table 1, dwarfs at solar metallicity:
    ``5040 K / T = 0.4929 + 0.5092 C - 0.0353 C^2``. Calibrated for 0.39 <= C <= 1.50; the
    quadratic is carried on (monotonic) over -0.5..4.5, past which the colour is clipped."""
    c = np.clip(np.asarray(bp_rp, dtype=np.float64), -0.5, 4.5)
    return 5040.0 / (0.4929 + 0.5092 * c - 0.0353 * c * c)


_BV_GRID = np.linspace(-0.4, 2.5, 2901)


def bv_from_bp_rp(bp_rp) -> np.ndarray:
    """The B-V whose temperature (:func:`temperature_from_bv`) is that of Gaia colour
    ``bp_rp`` (:func:`temperature_from_bp_rp`), so both catalogs' stars take one black
    body per temperature; NaN stays NaN. Clipped to the band model's -0.4..2.5."""
    t = temperature_from_bp_rp(bp_rp)
    grid_t = temperature_from_bv(_BV_GRID)  # falls as B-V grows: interp needs it rising
    return np.where(np.isfinite(t), np.interp(t, grid_t[::-1], _BV_GRID[::-1]), np.nan)


def _photons(temperature: np.ndarray) -> np.ndarray:
    """Black-body photon spectra (arbitrary scale), one row per temperature."""
    lam = _WAVELENGTH_NM[None, :]
    x = _H_C_OVER_K_NM / (lam * np.asarray(temperature, dtype=np.float64)[:, None])
    return 1.0 / (lam**4 * np.expm1(x))  # photons: B_lambda / (h c / lambda)


def _v_band() -> np.ndarray:
    sigma = 88.0 / 2.3548
    return np.exp(-0.5 * ((_WAVELENGTH_NM - 551.0) / sigma) ** 2)


@lru_cache(maxsize=8)
def _factors(band: Band, grid: tuple[float, ...]) -> np.ndarray:
    spectra = _photons(temperature_from_bv(np.array((*grid, REFERENCE_BV))))
    ratio = (spectra @ band.response()) / (spectra @ _v_band())
    return ratio[:-1] / ratio[-1]

__all__ = ["Band", "REFERENCE_BV", "bv_from_bp_rp", "temperature_from_bp_rp",
           "temperature_from_bv"]
