"""The lens of a simulated tracker: PSF model, field-varying aberrations, vignetting and
Brown-Conrady tangential distortion (the camera model carries the radial part).

PSF models (``psf``):

* ``gaussian``: today's round Gaussian of ``psf_sigma_px`` (the sensor's).
* ``airy``: the diffraction pattern of a circular aperture, ``[2 J1(x) / x]^2`` with the first
  dark ring at ``1.22 lambda N`` (``wavelength_nm``, ``f_number``, ``pixel_size_um``).
* ``defocus``: a uniform blur disk of ``defocus_radius_px`` whose edge is softened by the
  Gaussian (a lens focused short of the detector, as many trackers are on purpose).

Off axis, ``astigmatism`` stretches the spot radially (sigma x ``1 + astigmatism rho^2``)
and ``coma_px`` throws ``COMA_FRACTION`` of its light outward by ``coma_px rho^3`` (a tail
that biases the centroid away from the axis), with ``rho`` the distance from the principal
point over the half-diagonal. Vignetting dims both stars and sky: ``cos4`` is the natural
``cos^4 theta`` fall-off of the field angle ``theta``; ``profile`` interpolates a measured
relative illumination over ``rho`` (``profile_rho``, ``profile_value``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import TYPE_CHECKING

import numpy as np

from startrack.input_checks import Bounds
from startrack.simulate._effect_table import changed, choice, curve, number

if TYPE_CHECKING:  # the camera loads the compiled core: not for `--help`
    from startrack.camera import Camera

PSF_MODELS = ("gaussian", "airy", "defocus")
VIGNETTING = ("none", "cos4", "profile")
#: light a comatic spot throws into its outward tail
COMA_FRACTION = 0.3
_POSITIVE = Bounds(0.0, None, low_open=True)
_SMALL = Bounds(0.0, 100.0)


@dataclass(frozen=True)
class Optics:
    """The lens beyond the pinhole camera; every default leaves today's frames as they are."""

    psf: str = choice("gaussian", PSF_MODELS, "PSF model")
    wavelength_nm: float = number(600.0, Bounds(200.0, 2000.0), "centre of the band (airy)")
    f_number: float = number(1.9, Bounds(0.5, 64.0), "focal ratio N (airy)")
    pixel_size_um: float = number(5.5, Bounds(0.5, 100.0), "pixel pitch (airy)")
    defocus_radius_px: float = number(2.0, Bounds(0.1, 50.0), "blur-disk radius (defocus)")
    astigmatism: float = number(0.0, _SMALL, "radial stretch at the corner, fraction")
    coma_px: float = number(0.0, _SMALL, "outward throw of the coma tail at the corner, px")
    vignetting: str = choice("none", VIGNETTING, "vignetting model")
    profile_rho: tuple[float, ...] = curve("profile radii over the half-diagonal, 0..1")
    profile_value: tuple[float, ...] = curve("relative illumination at profile_rho")
    p1: float = number(0.0, Bounds(-0.1, 0.1), "Brown-Conrady tangential p1")
    p2: float = number(0.0, Bounds(-0.1, 0.1), "Brown-Conrady tangential p2")

    def __post_init__(self) -> None:
        if self.vignetting == "profile":
            rho, value = np.asarray(self.profile_rho), np.asarray(self.profile_value)
            if len(rho) < 2 or len(rho) != len(value):
                raise ValueError("profile_rho and profile_value must be lists of one "
                                 "length, at least 2")
            if np.any(np.diff(rho) <= 0) or np.any(value <= 0) or np.any(value > 1.5):
                raise ValueError("profile_rho must increase and profile_value lie in "
                                 "(0, 1.5]")

    @property
    def is_off(self) -> bool:
        return not changed(self)

    @property
    def shaped(self) -> bool:
        """True when spots need the general (compiled) PSF renderer, not the Gaussian one."""
        return self.psf != "gaussian" or self.astigmatism > 0 or self.coma_px > 0

    @property
    def airy_radius_px(self) -> float:
        """Radius of the Airy pattern's first dark ring, px."""
        return 1.22 * self.wavelength_nm * 1e-3 * self.f_number / self.pixel_size_um

    def tangential(self, camera: Camera, x: np.ndarray, y: np.ndarray):
        """Pixel positions moved by the tangential terms (p1, p2) of Brown-Conrady."""
        if self.p1 == 0.0 and self.p2 == 0.0:
            return x, y
        u, v = (x - camera.cx) / camera.f_px, (y - camera.cy) / camera.f_px
        r2 = u * u + v * v
        du = 2.0 * self.p1 * u * v + self.p2 * (r2 + 2.0 * u * u)
        dv = self.p1 * (r2 + 2.0 * v * v) + 2.0 * self.p2 * u * v
        return x + camera.f_px * du, y + camera.f_px * dv

    def relative_illumination(self, camera: Camera, x, y) -> np.ndarray:
        """Vignetting factor (1 on axis) at pixel positions ``x``, ``y``."""
        dx, dy = np.asarray(x) - camera.cx, np.asarray(y) - camera.cy
        if self.vignetting == "cos4":
            cos2 = camera.f_px**2 / (camera.f_px**2 + dx * dx + dy * dy)
            return cos2 * cos2
        if self.vignetting == "profile":
            rho = np.hypot(dx, dy) / _half_diagonal(camera)
            return np.interp(rho, self.profile_rho, self.profile_value)
        return np.ones(np.shape(dx))

    def illumination_map(self, camera: Camera) -> np.ndarray | None:
        """The vignetting over the whole frame (H x W float32), None without vignetting."""
        if self.vignetting == "none":
            return None
        return _map(self, camera)

    def spots(self, camera: Camera, x: np.ndarray, y: np.ndarray, electrons: np.ndarray,
              sigma: float) -> dict[str, np.ndarray]:
        """Per-spot PSF parameters for the compiled renderer (coma adds a tail spot per
        star): positions, electrons, model, two sizes and the radial direction."""
        n = len(x)
        dx, dy = x - camera.cx, y - camera.cy
        r = np.hypot(dx, dy)
        rho = r / _half_diagonal(camera)
        safe = np.where(r > 0, r, 1.0)
        cos_a, sin_a = np.where(r > 0, dx / safe, 1.0), np.where(r > 0, dy / safe, 0.0)
        model = PSF_MODELS.index(self.psf)
        size_a = {"gaussian": np.full(n, sigma), "airy": np.full(n, self.airy_radius_px),
                  "defocus": np.full(n, self.defocus_radius_px)}[self.psf]
        size_b = np.full(n, sigma)
        if self.psf == "gaussian":
            size_a = sigma * (1.0 + self.astigmatism * rho**2)
        spots = {"x": x, "y": y, "electrons": electrons, "model": np.full(n, model, np.int32),
                 "a": size_a, "b": size_b, "cos": cos_a, "sin": sin_a}
        if self.coma_px > 0 and n:
            throw = self.coma_px * rho**3
            tail = {"x": x + throw * cos_a, "y": y + throw * sin_a,
                    "electrons": electrons * COMA_FRACTION,
                    "model": np.zeros(n, np.int32), "a": sigma * (1.0 + 2.0 * rho),
                    "b": np.full(n, sigma), "cos": cos_a, "sin": sin_a}
            spots["electrons"] = electrons * (1.0 - COMA_FRACTION)
            spots = {k: np.concatenate([spots[k], tail[k]]) for k in spots}
        return spots


def _half_diagonal(camera: Camera) -> float:
    return 0.5 * math.hypot(camera.width, camera.height)


@lru_cache(maxsize=4)
def _map(optics: Optics, camera: Camera) -> np.ndarray:
    """The frame's vignetting, computed once per lens and camera (frames share it)."""
    rows = np.arange(camera.height, dtype=np.float64)[:, None]
    cols = np.arange(camera.width, dtype=np.float64)[None, :]
    out = optics.relative_illumination(camera, cols, rows).astype(np.float32)
    out.setflags(write=False)
    return out

__all__ = ["COMA_FRACTION", "Optics", "PSF_MODELS", "VIGNETTING"]
