"""What ``calibrate`` may claim about each camera parameter: its 1-sigma, and whether the
data moved it at all.

The covariance comes from the least-squares fit (its Jacobian, the noise estimated from
its residuals). A parameter the fit moves by more than :data:`SIGNIFICANCE` sigma from
its nominal value is **fitted**: the data reject the nominal value. Otherwise it keeps
the nominal value, and is reported **not constrained** when its 1-sigma moves a star at
the image corner by more than the fit's RMS per star (the data cannot place it better
than one star's noise; a lens coefficient is then left at 0), else **as given** (the
data agree with it: a pinhole whose sidecar gave the exact camera stays exactly that
camera). The fitted ones are then fitted again with the held ones fixed
(startrack.solver._calibrate).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import asdict, dataclass

import numpy as np

from startrack.camera import Camera

#: a fitted value within this many sigma of the nominal one keeps the nominal value
SIGNIFICANCE = 3.0
NAMES = ("fov_deg", "cx", "cy", "k1", "k2", "k3")


@dataclass(frozen=True)
class Parameter:
    """One camera parameter: ``value`` as written, ``fit`` and ``sigma`` (1-sigma) from
    the fit (None when not fitted), ``status``: "fitted", "as given", "not constrained"
    or "not fitted"."""

    name: str
    value: float
    nominal: float
    fit: float | None
    sigma: float | None
    status: str

    def to_dict(self) -> dict:
        return asdict(self)


def _values(camera: Camera) -> np.ndarray:
    d = camera.distortion
    k = (d.k1, d.k2, d.k3) if d is not None else (0.0, 0.0, 0.0)
    return np.array([camera.fov_deg, camera.cx, camera.cy, *k], dtype=np.float64)


def parameters(fit, nominal: Camera) -> tuple[tuple[Parameter, ...], np.ndarray]:
    """Each parameter's report, and the mask (over the model's parameters) of those held
    at their nominal values."""
    free = fit.free if fit.free is not None else np.zeros(6, bool)
    sigma_internal = np.full(6, np.nan)
    if fit.cov is not None:
        sigma_internal[free] = np.sqrt(np.clip(np.diag(fit.cov), 0.0, None))
    f = fit.camera.f_px
    half_w = fit.camera.width / 2.0
    # the fov's change per unit log focal length: d/dlnf of 2 atan(W / 2f)
    dfov = math.degrees(2.0 * (half_w / f) / (1.0 + (half_w / f) ** 2))
    sigma = sigma_internal * np.array([dfov, 1, 1, 1, 1, 1])
    corner = _corner_radius(fit.camera)
    u = corner / f
    effect_px = sigma_internal * np.array([corner, 1, 1, f * u ** 3, f * u ** 5, f * u ** 7])
    fitted, given = _values(fit.camera), _values(nominal)
    hold = np.zeros(6, bool)
    report = []
    for i, name in enumerate(NAMES):
        if not free[i]:
            report.append(Parameter(name, float(given[i]), float(given[i]), None, None,
                                    "not fitted"))
            continue
        if abs(fitted[i] - given[i]) > SIGNIFICANCE * sigma[i]:
            status, value = "fitted", fitted[i]
        elif not effect_px[i] <= fit.rms:  # NaN (a singular fit) is not constrained either
            status, value = "not constrained", (0.0 if i >= 3 else given[i])
            hold[i] = True
        else:
            status, value, hold[i] = "as given", given[i], True
        report.append(Parameter(name, float(value), float(given[i]), float(fitted[i]),
                                float(sigma[i]), status))
    return tuple(report), hold


def with_final(report, camera: Camera) -> tuple[Parameter, ...]:
    """``report`` with each fitted parameter's value taken from the final ``camera`` (the
    refit with the held parameters fixed)."""
    values = _values(camera)
    return tuple(dataclasses.replace(p, value=float(values[i])) if p.status == "fitted"
                 else p for i, p in enumerate(report))


def _corner_radius(camera: Camera) -> float:
    """Pixels from the principal point to the farthest image corner."""
    xs = np.array([-0.5, camera.width - 0.5]) - camera.cx
    ys = np.array([-0.5, camera.height - 0.5]) - camera.cy
    return float(np.hypot(np.abs(xs).max(), np.abs(ys).max()))


def format_parameters(report) -> list[str]:
    """One line per parameter for the terminal."""
    lines = []
    for p in report:
        if p.fit is None:
            lines.append(f"  {p.name:8s} {p.value:.6g} (not fitted)")
            continue
        measured = f"fit {p.fit:.6g} +- {p.sigma:.2g}"
        if p.status == "fitted":
            lines.append(f"  {p.name:8s} {p.value:.6g} +- {p.sigma:.2g} (1 sigma)")
        elif p.status == "as given":
            lines.append(f"  {p.name:8s} {p.value:.6g} as given ({measured}: within "
                         f"{SIGNIFICANCE:g} sigma of it)")
        else:
            lines.append(f"  {p.name:8s} {p.value:.6g}: not constrained by the data "
                         f"({measured}), left at {p.value:g}")
    return lines
