"""A frame as the compiled verification takes it: its observed stars, its camera and the
thresholds as named structures (:mod:`startrack._core.verify.entry_points`), built once per
frame and
asked once per hypothesis (:class:`FrameVerifier`)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from startrack._core.verify.entry_points import Stars, Verdict, Verifier, frame_through
from startrack.camera import Camera
from startrack.match_records import Observation
from startrack.verify._labelling import label_params

if TYPE_CHECKING:
    from startrack.database import StarDatabase
    from startrack.verify._verification import VerifyConfig

__all__ = ["CAPTURE", "CONE_LOOKUP_MARGIN", "MAX_REFINEMENTS", "FrameVerifier",
           "camera_geometry", "cone_radius"]

MAX_REFINEMENTS = 5
# The catalog cone around a boresight: 2% beyond the farthest image corner, so that a star
# just outside the frame edge whose match radius reaches into the image is still projected.
CONE_MARGIN = 1.02
# A cone is reused while the boresight moves less than this fraction of its radius
# (refinement moves it by arcseconds) ...
CONE_REUSE_FRACTION = 0.01
# ... and is looked up this much wider, so that such a move keeps every image star in it.
CONE_LOOKUP_MARGIN = 1.01
CAPTURE = 3.0  # the wider capture of a refinement, in match radii


def cone_radius(camera: Camera) -> float:
    """Radius of the catalog cone that holds every star of an image around its boresight."""
    return math.radians(camera.half_diagonal_deg) * CONE_MARGIN


def camera_geometry(camera: Camera) -> dict:
    """The camera as the compiled projection takes it (the fields of ``Geometry``: the
    pinhole, and the lens's k1, k2, k3 and fold radius, zeros and inf without one), as
    its compiled optics hold it."""
    return camera.optics.geometry


def _as(array: np.ndarray, dtype: type = np.float64) -> np.ndarray:
    return np.ascontiguousarray(array, dtype=dtype)


class FrameVerifier:
    """One frame's verification under ``config``: the catalog stars come from a cone
    around each hypothesis's attitude, or from the sorted catalog ``rows`` given (e.g.
    those around a tracking prediction).

    Parameters
    ----------
    obs : Observation
        The frame's observed stars.
    database : StarDatabase
        The catalog (its vectors, magnitudes and cone index).
    config : VerifyConfig
        The match radius and the acceptance thresholds.
    rows : numpy.ndarray, optional
        Fixed catalog rows to verify against instead of a cone.
    """

    def __init__(self, obs: Observation, database: StarDatabase, config: VerifyConfig,
                 rows: np.ndarray | None = None) -> None:
        camera = obs.camera
        radius = config.radius_px(obs)
        cone_rad = cone_radius(camera)
        params = {"radius_px": radius, "cos_radius": math.cos(radius / camera.f_px),
                  "cone_radius": cone_rad * CONE_LOOKUP_MARGIN,
                  "margin_cos": math.cos(CONE_REUSE_FRACTION * cone_rad),
                  "capture": CAPTURE, "max_rounds": MAX_REFINEMENTS,
                  "min_confirmed": config.min_confirmed,
                  "max_probability": config.max_false_probability,
                  "max_stars": config.catalog_stars,
                  "label": label_params(obs, radius)}
        frame = frame_through(camera.optics, _as(obs.vectors), _as(obs.x), _as(obs.y),
                              obs.kernel_flux())
        mags = _as(database.catalog.mag)
        stars = None
        if rows is not None:
            rows = _as(rows, np.int64)
            stars = Stars(_as(database.vectors[rows]), _as(mags[rows]), rows)
        self.radius_px = radius
        self.params = params  # the thresholds (CheckParams' fields) this frame checks with
        self.vectors = obs.vectors  # what an accepted Verification's residuals refer to
        self._verifier = Verifier(frame, params, database.cone_index.table, mags, stars)

    def check(self, obs_index: np.ndarray, cat_index: np.ndarray) -> Verdict:
        """Verify that observed star ``obs_index[k]`` is catalog row ``cat_index[k]``
        (int64 arrays of distinct, in-range indices; others are refused)."""
        return self._verifier.check(obs_index, cat_index)
