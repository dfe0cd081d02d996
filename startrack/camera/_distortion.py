"""Lens distortion of docs/conventions.md: Brown-Conrady radial, ideal pinhole <-> observed.

Coordinates here are normalised: ``u = (x - cx) / f``, ``v = (y - cy) / f``. The model maps
the ideal pinhole point to the observed one, ``u_obs = u * (1 + k1 r2 + k2 r2^2 + k3 r2^3)``
with ``r2 = u^2 + v^2``; the inverse is found by Newton's method on the radius. Both are
computed by the compiled core (:class:`startrack._core.camera.optics.RadialLens`).
(FITS TAN-SIP terms of this model: :func:`startrack.outputs._wcs.sip_from_camera`.)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from startrack._core.camera.optics import RadialLens
from startrack.errors import InputError
from startrack.input_checks import check_number

MODELS = ("radial",)
_KEYS = {"model", "k1", "k2", "k3"}


@dataclass(frozen=True)
class RadialDistortion:
    """Brown-Conrady radial distortion with coefficients k1, k2, k3 (dimensionless)."""

    k1: float = 0.0
    k2: float = 0.0
    k3: float = 0.0

    @property
    def is_identity(self) -> bool:
        return self.k1 == 0.0 and self.k2 == 0.0 and self.k3 == 0.0

    def factor(self, r2: np.ndarray) -> np.ndarray:
        """The radial scale ``1 + k1 r2 + k2 r2^2 + k3 r2^3``."""
        return 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3))

    @cached_property
    def max_r2(self) -> float:
        """Ideal r^2 up to which the observed radius still grows with the ideal one (the
        model is invertible there); ``inf`` when it never folds back. Computed once per
        model: every projection and inversion through it asks."""
        # Roots in r2 of 1 + 3 k1 s + 5 k2 s^2 + 7 k3 s^3 = 0; the smallest positive one.
        if self.k2 == 0.0 and self.k3 == 0.0:  # k1 alone (a fitted lens): no polynomial
            return -1.0 / (3.0 * self.k1) if self.k1 < 0.0 else math.inf
        roots = np.roots([7.0 * self.k3, 5.0 * self.k2, 3.0 * self.k1, 1.0])
        real = roots[np.abs(roots.imag) < 1e-12].real
        positive = real[real > 0]
        return float(positive.min()) if len(positive) else math.inf

    @cached_property
    def compiled(self) -> RadialLens:
        """The model as the compiled core takes it (its one implementation of the
        distortion and its inverse), built once per model."""
        return RadialLens(self.k1, self.k2, self.k3, self.max_r2)

    def distort(self, u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Observed normalised coordinates of ideal ones."""
        return self.compiled.distort(u, v)

    def undistort(self, ud: np.ndarray, vd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Ideal normalised coordinates of observed ones: Newton on the radius, every
        point stepped until no step exceeds 1e-15 (at most 12 steps: it converges
        quadratically), clipped to the fold radius."""
        return self.compiled.undistort(ud, vd)

    def to_dict(self) -> dict:
        return {"model": "radial", "k1": self.k1, "k2": self.k2, "k3": self.k3}


def _number(value, key: str, where: str) -> float:
    return float(check_number(value, f"{where}: distortion '{key}'"))


def distortion_from_dict(data, where: str = "camera") -> RadialDistortion | None:
    """The ``distortion`` entry of a camera file (docs/conventions.md); None for no distortion."""
    if data is None:
        return None
    if not isinstance(data, dict):
        raise InputError(f"{where}: 'distortion' must be a table such as "
                         '{"model": "radial", "k1": -0.1}')
    unknown = set(data) - _KEYS
    if unknown:
        raise InputError(f"{where}: unknown distortion key(s) {', '.join(sorted(unknown))}")
    model = data.get("model")
    if model not in MODELS:
        raise InputError(f"{where}: distortion 'model' must be one of {', '.join(MODELS)}, "
                         f"got {model!r}")
    k = {key: _number(data.get(key, 0.0), key, where) for key in ("k1", "k2", "k3")}
    return RadialDistortion(**k)
