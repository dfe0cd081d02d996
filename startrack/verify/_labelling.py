"""Final labelling: which observed star is reported as which catalog star, once the attitude
is accepted; one-to-one, and a star is left unidentified rather than guessed.

Verification decides whether the attitude is right; this module decides which identities
are certain enough to report at that attitude. The catalog stars are projected into the
image; every observed star within the match radius of one is a candidate. A candidate
pair is reported only when all of these hold:

* brightness: when the stars carry a flux, the zero point of ``-2.5 log10(flux)`` against
  the catalog magnitude is fitted over the isolated pairs (one candidate each way), with
  its robust scatter; a candidate whose magnitude is off by more than ``mag_sigmas`` times
  that scatter is no candidate (a false star, or the wrong star of a close pair);
* resolution: no other catalog star lies within ``resolve_px`` of the catalog star (the
  optics see one spot; which star it is would be a coin toss), nor within
  ``resolve_sigmas`` times the frame's stated centroid noise (the noise moves a spot that
  far: at that noise the pair is as ambiguous);
* no rival: the observed star's next catalog candidate, and the catalog star's next
  observed candidate (one not clearly matched elsewhere), are at least ``1/ambiguity``
  times less likely by their residuals, with the residual scatter fitted over the
  isolated pairs;
* not a coincidence: a false star landing that close to an unobserved catalog star (the
  false-star density and the unobserved fraction measured in this frame; its brightness
  uniform over the catalog magnitudes in view) is at most ``false_odds`` times as likely
  as the true star at that residual and brightness (``false_odds_flux``, stricter, when
  the stars carry fluxes: a false star of the right brightness by chance is otherwise
  credited as the star). This is what keeps out a residual
  far beyond the other matches' scatter.

The arithmetic is one compiled call, :func:`startrack._core.verify.entry_points.label_stars`
(the same
labelling verification runs inside its own compiled call).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from startrack._core.verify.entry_points import label_stars as _label_stars
from startrack.match_records import Observation

#: Catalog stars closer than this many pixels are one spot (as startrack.sky merges them).
RESOLVE_PX = 2.0
#: The reasons a star with a candidate is withheld, in the order they are tested.
REASONS = ("brightness", "unresolved", "ambiguous", "coincidence")


@dataclass(frozen=True)
class LabelConfig:
    """Thresholds of the final labelling (see the module docstring)."""

    ambiguity: float = 1e-3
    false_odds: float = 1e-3
    # With fluxes a false star of the right brightness by chance gets the true star's
    # brightness credit; 1e-3 let one 3.3 px from an unobserved star be labelled
    # (scripts/validation/harsh_frames.py, seed 3), so the odds asked are stricter there
    false_odds_flux: float = 1e-4
    resolve_px: float = RESOLVE_PX
    # A catalog star with another within this many times the frame's stated centroid noise
    # (when that is more than resolve_px) is as ambiguous: the noise moves a spot that far
    resolve_sigmas: float = 2.0
    mag_sigmas: float = 5.0
    min_mag_sigma: float = 0.03  # mag: the floor of the fitted brightness scatter
    min_sigma_px: float = 0.02  # px: the floor of the fitted residual scatter
    min_fit: int = 5  # isolated pairs needed to fit the scatters


# Built once: every frame's verification asks for the labelling's thresholds
_DEFAULT_CONFIG = LabelConfig()


@dataclass(frozen=True)
class Labelling:
    """The reported identities (``obs_index`` ascending, ``cat_index`` catalog rows) and
    how many observed stars with a candidate were left unidentified, by reason."""

    obs_index: np.ndarray
    cat_index: np.ndarray
    withheld: dict[str, int] = field(default_factory=dict)
    sigma_px: float = float("nan")  # fitted residual scatter per axis
    mag_sigma: float | None = None  # fitted brightness scatter; None: not used


def label_stars(obs: Observation, rows: np.ndarray, x: np.ndarray, y: np.ndarray,
                mag: np.ndarray, radius_px: float,
                config: LabelConfig | None = None) -> Labelling:
    """Report each observed star as a catalog star only where nothing else is plausible.

    Parameters
    ----------
    obs : Observation
        The frame's observed stars (``flux`` optional).
    rows, x, y, mag : numpy.ndarray
        The catalog stars projected at the accepted attitude: catalog rows, pixel
        positions and catalog magnitudes.
    radius_px : float
        The match radius of verification, in pixels.
    config : LabelConfig, optional
        Thresholds; the defaults when None.

    Returns
    -------
    Labelling
        One-to-one identities, and the count of withheld stars per reason
        (``brightness``, ``unresolved``, ``ambiguous``, ``coincidence``).
    """
    config = config or _DEFAULT_CONFIG
    x, y, mag = (np.ascontiguousarray(a, dtype=np.float64) for a in (x, y, mag))
    rows = np.ascontiguousarray(rows, dtype=np.int64)
    flux = obs.kernel_flux()
    # The compiled call does not check bounds: unequal lengths must not reach it.
    if not (len(obs.x) == len(obs.y) == len(flux) and len(x) == len(y) == len(mag)
            == len(rows)):
        raise ValueError("label_stars: observed or catalog arrays of unequal lengths")
    obs_index, cat_index, withheld, sigma, mag_sigma, used = _label_stars(
        np.ascontiguousarray(obs.x, dtype=np.float64),
        np.ascontiguousarray(obs.y, dtype=np.float64), x, y, mag, rows, flux,
        label_params(obs, radius_px, config))
    return Labelling(obs_index, cat_index, dict(zip(REASONS, withheld.tolist(), strict=True)),
                     sigma, mag_sigma if used else None)


def label_params(obs: Observation, radius_px: float, config: LabelConfig | None = None,
                 ) -> dict:
    """The labelling's thresholds for this frame as the compiled labelling takes them
    (the fields of its ``LabelParams`` structure: logs and squares taken)."""
    config = config or _DEFAULT_CONFIG
    sigma_px = float(obs.sigma_rad * obs.camera.f_px)
    resolve = max(float(config.resolve_px), config.resolve_sigmas * sigma_px)
    return {  # squares as products, as the compiled fit-and-verify rounds take them
        "has_flux": obs.flux is not None,
        "radius2": float(radius_px) * float(radius_px),
        "sigma0": sigma_px,
        "area": float(obs.camera.width * obs.camera.height),
        "log_gap": math.log(config.ambiguity),
        "log_false_odds": math.log(config.false_odds_flux if obs.flux is not None
                                   else config.false_odds),
        "resolve2": resolve * resolve,
        "mag_sigmas": float(config.mag_sigmas),
        "min_mag_sigma": float(config.min_mag_sigma),
        "min_sigma_px": float(config.min_sigma_px),
        "min_fit": int(config.min_fit),
    }
