"""The space environment in a frame: cosmic-ray hits, stray light and a bright body.

* Cosmic rays: hits arrive at ``cosmic_rays`` per cm^2 per s over the detector's area
  during the exposure (a Poisson process; :data:`LEO_FLUX` and :data:`SAA_FLUX` are the
  quiet-orbit and South Atlantic Anomaly cases). Each comes in at an angle drawn for an
  isotropic flux on a plane (``cos theta`` uniform in its square), crosses the
  ``depth_um``-deep sensitive layer and leaves :data:`ELECTRONS_PER_UM` of charge per
  micrometre of path: a one- or two-pixel spot when it comes in steeply, a track of
  ``depth tan theta / pixel`` pixels when it grazes.
* Stray light (Sun, Moon or Earth limb outside the field, scattered by the baffle): a
  background of ``stray_light`` e-/px/s at the field's centre that grows by ``stray_gradient``
  across the field towards ``stray_angle_deg`` (image angle, from +x towards +y). When
  the source is within ``exclusion_deg`` of the boresight (``source_angle_deg``), the
  tracker is blinded: every pixel is at full well.
* A body in the field (the Moon, a planet): a disk of ``body_radius_deg`` at pixel
  (``body_x``, ``body_y``) holding the light of magnitude ``body_mag`` (Moon: -12.7, 0.26
  deg; Venus -4, Jupiter -2.5: below a pixel, a point).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from startrack.input_checks import Bounds
from startrack.simulate._effect_table import changed, number

if TYPE_CHECKING:  # the camera loads the compiled core: not for `--help`
    from startrack.camera import Camera

#: hits per cm^2 per s: galactic cosmic rays and trapped protons in a quiet low orbit
#: (Hubble's detectors count about 1 to 5; JWST's about 5)
LEO_FLUX = 5.0
#: the South Atlantic Anomaly's core at 500-800 km: of the order of 10^2 to 10^3 protons
#: per cm^2 per s above 10 MeV (AP-8/AP-9); the heavy case
SAA_FLUX = 500.0
#: electron-hole pairs a minimum-ionising particle frees per micrometre of silicon
ELECTRONS_PER_UM = 80.0
MAX_TRACK_PX = 64.0  # the grazing tail of the angle distribution is capped
_NONE = Bounds(0.0, None)


@dataclass(frozen=True)
class Environment:
    """Space effects; every default leaves today's frames as they are."""

    cosmic_rays: float = number(0.0, Bounds(0.0, 1e5), "cosmic-ray flux, hits/cm^2/s")
    depth_um: float = number(10.0, Bounds(1.0, 100.0), "sensitive depth of the pixels, um")
    pixel_size_um: float = number(5.5, Bounds(0.5, 100.0), "pixel pitch, um")
    stray_light: float = number(0.0, Bounds(0.0, 1e9), "stray light at the centre, e-/px/s")
    stray_gradient: float = number(1.0, Bounds(0.0, 100.0),
                                   "stray light across the field, relative rise")
    stray_angle_deg: float = number(0.0, Bounds(-360.0, 360.0),
                                    "image direction of the stray-light source, deg")
    source_angle_deg: float = number(180.0, Bounds(0.0, 180.0),
                                     "angle of the source from the boresight, deg")
    exclusion_deg: float = number(0.0, Bounds(0.0, 180.0), "blinding half-angle, deg")
    body_mag: float = number(99.0, Bounds(-30.0, 99.0), "magnitude of a body in view (99: none)")
    body_radius_deg: float = number(0.0, Bounds(0.0, 5.0), "its angular radius, deg")
    body_x: float = number(0.0, _NONE, "its centre, px")
    body_y: float = number(0.0, _NONE, "its centre, px")

    @property
    def is_off(self) -> bool:
        return not changed(self)

    @property
    def blinded(self) -> bool:
        return self.source_angle_deg < self.exclusion_deg

    def stray_map(self, camera: Camera, exposure_s: float) -> np.ndarray | None:
        """Stray-light electrons over the frame (H x W float32), None without any."""
        if self.stray_light == 0:
            return None
        a = math.radians(self.stray_angle_deg)
        half = 0.5 * math.hypot(camera.width, camera.height)
        cols = (np.arange(camera.width, dtype=np.float32) - camera.cx) * np.float32(math.cos(a))
        rows = (np.arange(camera.height, dtype=np.float32) - camera.cy) * np.float32(math.sin(a))
        toward = (rows[:, None] + cols[None, :]) / np.float32(half)  # -1 .. 1 across
        rise = np.float32(math.log1p(self.stray_gradient) / 2.0)
        return np.exp(rise * toward) * np.float32(self.stray_light * exposure_s)

    def cosmic_tracks(self, camera: Camera, exposure_s: float, rng: np.random.Generator):
        """This exposure's hits: start (x, y) px, projected length px, direction (rad) and
        charge (e-) of each.

        The hits are the first of a fixed per-frame sequence (unit-rate arrival times
        under ``flux x area x exposure``), so a heavier flux keeps a lighter one's hits.
        """
        area_cm2 = camera.width * camera.height * (self.pixel_size_um * 1e-4) ** 2
        expected = self.cosmic_rays * area_cm2 * exposure_s
        if expected <= 0:
            return tuple(np.zeros(0) for _ in range(5))
        arrivals, u = _hit_sequence(expected, rng)
        n = int(np.searchsorted(arrivals, expected))
        u = u[:n]
        cos_t = np.sqrt(np.maximum(u[:, 2], 1e-6))  # isotropic on a plane: cos^2 uniform
        tan_t = np.sqrt(1.0 - cos_t**2) / cos_t
        length = np.minimum(self.depth_um * tan_t / self.pixel_size_um, MAX_TRACK_PX)
        return (u[:, 0] * camera.width - 0.5, u[:, 1] * camera.height - 0.5, length,
                2.0 * math.pi * u[:, 3], ELECTRONS_PER_UM * self.depth_um / cos_t)

    def cosmic_hits(self, camera: Camera, exposure_s: float, rng: np.random.Generator):
        """Pixel (rows, cols) and electrons of this exposure's cosmic-ray charge, two
        samples a pixel along each track."""
        x0, y0, length, phi, charge = self.cosmic_tracks(camera, exposure_s, rng)
        steps = np.maximum(np.ceil(2.0 * length).astype(np.int64), 1)
        which = np.repeat(np.arange(len(x0)), steps)
        first = np.cumsum(steps) - steps
        t = (np.arange(len(which)) - first[which] + 0.5) / steps[which] - 0.5
        xs = x0[which] + t * length[which] * np.cos(phi[which])
        ys = y0[which] + t * length[which] * np.sin(phi[which])
        cols, rows = np.floor(xs + 0.5).astype(np.int64), np.floor(ys + 0.5).astype(np.int64)
        ok = (cols >= 0) & (cols < camera.width) & (rows >= 0) & (rows < camera.height)
        return rows[ok], cols[ok], (charge / steps)[which][ok]

    def body_disk(self, camera: Camera) -> tuple[float, float, float] | None:
        """(x, y, radius px) of the body in view, None without one."""
        if self.body_mag >= 99.0:
            return None
        return self.body_x, self.body_y, camera.f_px * math.tan(math.radians(
            self.body_radius_deg))

_BLOCK = 256  # hits drawn at a time: row k of the sequence is the same whatever the flux


def _hit_sequence(expected: float, rng: np.random.Generator):
    """Arrival times (unit rate) and 4 uniforms per hit, block by block until past
    ``expected``: the first k hits are the same for every flux."""
    times, uniforms, last = [], [], 0.0
    while last <= expected:
        steps = rng.exponential(size=_BLOCK)
        uniforms.append(rng.random((_BLOCK, 4)))
        times.append(last + np.cumsum(steps))
        last = float(times[-1][-1])
    return np.concatenate(times), np.concatenate(uniforms)


__all__ = ["ELECTRONS_PER_UM", "Environment", "LEO_FLUX", "MAX_TRACK_PX", "SAA_FLUX"]
