"""The data that passes between the identification stages: observed stars, hypotheses,
what a matcher did, and the solution of one frame.

These live apart from the matchers so that verification, identify, output and the bench
depend on the stage types, not on the plugin package.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

from startrack.camera import Camera


@dataclass(frozen=True)
class Observation:
    """Observed stars of one frame, brightest first.

    ``vectors`` are camera-frame unit vectors (N x 3) of the pixel positions ``x``, ``y``;
    ``sigma_rad`` is the 1-sigma angular error of one centroid along one axis, from which
    matchers derive their tolerances. ``flux`` (optional, linear, larger is brighter) lets
    the final labelling check brightness.
    """

    vectors: np.ndarray
    x: np.ndarray
    y: np.ndarray
    camera: Camera
    sigma_rad: float
    flux: np.ndarray | None = None

    @classmethod
    def from_pixels(cls, x: np.ndarray, y: np.ndarray, camera: Camera,
                    sigma_px: float, flux: np.ndarray | None = None) -> Observation:
        x = np.asarray(x, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        flux = None if flux is None else np.asarray(flux, dtype=np.float64)
        return cls(camera.pixel_to_vector(x, y), x, y, camera, float(sigma_px) / camera.f_px,
                   flux)

    def __len__(self) -> int:
        return len(self.x)

    def kernel_flux(self) -> np.ndarray:
        """The fluxes as the compiled kernels take them (float64, contiguous), the x
        positions standing in when there are none (the kernels are told which)."""
        return np.ascontiguousarray(self.x if self.flux is None else self.flux,
                                    dtype=np.float64)


@dataclass(frozen=True)
class Hypothesis:
    """Observed star ``obs_index[k]`` is catalog row ``cat_index[k]``."""

    obs_index: np.ndarray
    cat_index: np.ndarray


@dataclass
class MatchDiagnostics:
    """What a matcher did for one frame; the bench reports these per method."""

    candidates: int = 0  # catalog patterns returned by database lookups
    pivots: int = 0  # further lookups made to narrow down an ambiguous match
    hypotheses: int = 0  # hypotheses handed to verification
    #: a peer solver's own solve-call time; None for our matchers, timed by identify
    method_ms: float | None = None
    extra: dict = field(default_factory=dict)  # method-specific counters


@dataclass(frozen=True)
class Solution:
    """The answer for one frame: which observed star is which catalog row, and the
    attitude (camera to ICRS). ``solved`` is False when no hypothesis passed verification."""

    solved: bool
    method: str
    rotation: Rotation | None = None
    obs_index: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    cat_index: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    residual_arcsec: np.ndarray = field(default_factory=lambda: np.zeros(0))
    false_probability: float = 1.0
    diagnostics: MatchDiagnostics = field(default_factory=MatchDiagnostics)
    identify_ms: float = 0.0
    #: why an unsolved frame has no answer, in a word (docs/conventions.md): "too_few_stars",
    #: "no_match", "timeout"; None when solved
    reason: str | None = None
    #: how it was solved (docs/conventions.md): "lost_in_space" or "tracking"
    mode: str = "lost_in_space"
    #: in a tracked sequence, the lock state after this frame
    #: (startrack.tracking._lock_state.LOCK_STATES);
    #: None outside a sequence
    lock: str | None = None
    #: solved lost-in-space after a prior or tracking attempt failed: that attempt's reason
    #: ("no_track", "too_few_stars"); None otherwise (docs/conventions.md)
    fallback: str | None = None


@dataclass(frozen=True)
class Timing:
    """Milliseconds per stage of one input (``timing_ms``, docs/conventions.md).

    ``setup`` is the one-time cost this input paid (a catalog, database or matcher loaded,
    kernels compiled by a throwaway solve); it is not part of ``total``, which adds only
    the per-input stages.
    """

    centroid: float = 0.0
    identify: float = 0.0
    total: float = 0.0
    setup: float = 0.0

    def to_dict(self) -> dict:
        return {"centroid": round(self.centroid, 3), "identify": round(self.identify, 3),
                "total": round(self.total, 3), "setup": round(self.setup, 3)}

__all__ = ["Hypothesis", "MatchDiagnostics", "Observation", "Solution", "Timing"]
