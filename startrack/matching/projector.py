"""The catalog stars around an attitude, projected into one frame and paired with its
observed stars: the projection shared by verification, refinement, labelling and tracking.

The arithmetic is compiled (:mod:`startrack.matching.verify_kernels`); this class keeps
the frame's arrays and the cone of catalog stars that can fall in the image.
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import TYPE_CHECKING

import numpy as np

from startrack.camera._model import Camera
from startrack.matching import check_kernels
from startrack.matching import verify_kernels as kern
from startrack.types import Observation

if TYPE_CHECKING:
    from collections.abc import Callable

    from startrack.database import StarDatabase

MAX_REFINEMENTS = 5
# The catalog cone around a boresight: 2% beyond the farthest image corner, so that a star
# just outside the frame edge whose match radius reaches into the image is still projected.
CONE_MARGIN = 1.02
# A cached cone is reused while the boresight moves less than this fraction of its radius
# (refinement moves it by arcseconds) ...
CONE_REUSE_FRACTION = 0.01
# ... and is looked up this much wider, so that such a move keeps every image star in it.
CONE_LOOKUP_MARGIN = 1.01
CAPTURE = 3.0  # the wider capture of a refinement, in match radii (see refine)


@lru_cache(maxsize=64)
def cone_radius(camera: Camera) -> float:
    """Radius of the catalog cone that holds every star of an image around its boresight."""
    return math.radians(camera.half_diagonal_deg) * CONE_MARGIN


_last_camera: list = [None, None]  # the last camera seen and its constants


def _camera_constants(camera: Camera) -> tuple[np.ndarray, float]:
    """The camera's kernel geometry and cone radius; a frame sequence shares one camera,
    whose hash (two lru_cache look-ups) would cost more than the rest of a projector."""
    if _last_camera[0] is not camera:
        _last_camera[:] = [camera, (camera.geometry, cone_radius(camera))]
    return _last_camera[1]


_last_params: list = [None, None]  # the last frame constants' key and the packed array


class CatalogProjector:
    """The catalog stars around one attitude, projected into the image of ``obs``.

    Without ``rows`` the cone of candidate stars is looked up around the attitude asked
    for and reused while the boresight stays well inside its margin: refining an accepted
    attitude moves it by arcseconds, and the image test after the projection decides
    which stars are in, so the answer is the same as with a fresh cone. With ``rows``
    (sorted catalog rows, e.g. the stars around a tracking prediction) only those are
    projected.
    """

    def __init__(self, obs: Observation, database: StarDatabase, radius_px: float,
                 rows: np.ndarray | None = None) -> None:
        self.obs, self.database, self.radius_px = obs, database, float(radius_px)
        self.geometry, self.cone_rad = _camera_constants(obs.camera)
        self.ox = np.ascontiguousarray(obs.x, dtype=np.float64)
        self.oy = np.ascontiguousarray(obs.y, dtype=np.float64)
        self.obs_vectors = np.ascontiguousarray(obs.vectors, dtype=np.float64)
        self.margin_cos = math.cos(CONE_REUSE_FRACTION * self.cone_rad)
        self.fixed = rows is not None
        self.boresight = np.zeros(3)
        self._config = None  # the startrack.verify._verification.VerifyConfig of _packed
        if self.fixed:
            self._use(np.asarray(rows, np.int64))
        else:  # the first hypothesis looks its cone up
            self.rows, self.vectors = np.zeros(0, np.int64), np.zeros((0, 3))

    def _use(self, rows: np.ndarray) -> None:
        self.rows = rows
        self.vectors = np.ascontiguousarray(self.database.vectors[rows])
        if self.fixed:
            self.mags = np.ascontiguousarray(self.database.catalog.mag[rows], dtype=np.float64)

    def _params(self, config, kernel_params: Callable) -> np.ndarray:
        """The frame's constants for the check kernels under ``config`` (kept for the
        config last asked for: a frame's hypotheses share one; and across frames of one
        camera, noise and config, whose constants are the same but for the fluxes)."""
        if config is not self._config:
            obs = self.obs
            radius = config.radius_px(obs)
            margin = -2.0 if self.fixed else self.margin_cos
            key = (obs.camera, obs.sigma_rad, obs.flux is None, config, self.radius_px,
                   self.cone_rad * CONE_LOOKUP_MARGIN, margin, CAPTURE, MAX_REFINEMENTS,
                   kernel_params)
            if _last_params[0] != key:
                label = kernel_params(obs, radius)
                packed = check_kernels.pack_params(
                    self.radius_px, math.cos(radius / obs.camera.f_px), key[5], margin,
                    CAPTURE, MAX_REFINEMENTS, config.min_confirmed,
                    config.max_false_probability, label)
                _last_params[:] = [key, packed]
            self._packed = _last_params[1]
            self._flux = obs.kernel_flux()  # kernel_params' first value, per frame
            if not self.fixed:
                self.mags = np.ascontiguousarray(self.database.catalog.mag, dtype=np.float64)
            self._config = config
        return self._packed

    def check(self, obs_h: np.ndarray, cat_h: np.ndarray, config,
              kernel_params: Callable) -> tuple:
        """:func:`startrack.verify._verification.verify`'s steps in one compiled call
        (:mod:`startrack.matching.check_kernels`) on int64 arrays, the labelling's
        parameters from ``kernel_params`` (:func:`startrack.verify._labelling.kernel_params`,
        passed in: labelling sits above this package): (status, first matrix,
        observed index, catalog rows, false probability, confirmed, final matrix,
        residuals in arcseconds, quaternion). Unless the status is ACCEPTED the pairs are
        the first test's; after it (not REJECTED or BAD_INDEX) the projector holds the
        cone around the first attitude, as after :meth:`first_match`."""
        params = self._params(config, kernel_params)
        index = self.database.cone_index
        if self.fixed:
            return check_kernels.check_fixed(
                self.obs_vectors, self.ox, self.oy, self._flux, obs_h, cat_h, index.vectors,
                self.rows, self.vectors, self.mags, self.geometry, params)
        status, matrix, rows, vectors, *rest = check_kernels.check_cone(
            self.obs_vectors, self.ox, self.oy, self._flux, obs_h, cat_h, index.vectors,
            self.mags, index.order, index.ra_sorted, index.band_start, self.geometry, params)
        if status > check_kernels.REJECTED:
            self.rows, self.vectors, self.boresight = rows, vectors, matrix[:, 2].copy()
        return status, matrix, *rest

    def _around(self, matrix: np.ndarray) -> None:
        boresight = matrix[:, 2]
        if not self.fixed and float(boresight @ self.boresight) < self.margin_cos:
            self._use(self.database.cone(boresight, self.cone_rad * CONE_LOOKUP_MARGIN))
            self.boresight = boresight.copy()

    def first_match(self, obs_h: np.ndarray, sky_h: np.ndarray, cos_radius: float,
                    ) -> tuple[np.ndarray | None, np.ndarray, np.ndarray, int, int]:
        """A hypothesis's first test: the attitude fitted to its stars (observed ``obs_h``,
        catalog vectors ``sky_h``), None unless each pair lies within ``cos_radius`` of
        the other; then the frame matched at it. Returns (matrix, obs_index, cat_index,
        catalog stars in the image, matches outside the hypothesis)."""
        none = np.zeros(0, np.int64)
        if self.fixed:
            fits, matrix, obs_m, pos, n_in, confirmed = kern.first_match_fixed(
                self.obs_vectors, self.ox, self.oy, obs_h, sky_h, self.vectors, self.geometry,
                self.radius_px, cos_radius)
            if not fits:
                return None, none, none, 0, 0
            return matrix, obs_m, self.rows[pos], int(n_in), int(confirmed)
        index = self.database.cone_index
        fits, matrix, rows, vectors, obs_m, pos, n_in, confirmed = kern.first_match(
            self.obs_vectors, self.ox, self.oy, obs_h, sky_h, index.vectors, index.order,
            index.ra_sorted, index.band_start, self.cone_rad * CONE_LOOKUP_MARGIN, self.geometry,
            self.radius_px, cos_radius)
        if not fits:
            return None, none, none, 0, 0
        self.rows, self.vectors, self.boresight = rows, vectors, matrix[:, 2].copy()
        return matrix, obs_m, rows[pos], int(n_in), int(confirmed)

    def __call__(self, matrix: np.ndarray,
                 radius_px: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Rows and pixel positions of the catalog stars in the image widened by
        ``radius_px`` at the attitude ``matrix`` (camera to sky)."""
        self._around(matrix)
        x, y, inside = kern.project(self.vectors, np.ascontiguousarray(matrix),
                                    self.geometry, float(radius_px))
        return self.rows[inside], x[inside], y[inside]

    def match(self, matrix: np.ndarray,
              radius_px: float | None = None) -> tuple[np.ndarray, np.ndarray, int]:
        """Observed stars paired with the projected catalog stars within ``radius_px``
        (default: the match radius), each catalog star at most once (nearest wins):
        (obs_index ascending, cat_index, n_catalog_in_image)."""
        self._around(matrix)
        r = self.radius_px if radius_px is None else float(radius_px)
        obs_idx, pos, n_in = kern.match(self.vectors, np.ascontiguousarray(matrix), self.ox,
                                        self.oy, self.geometry, r)
        return obs_idx, self.rows[pos], int(n_in)

    def refine(self, obs_m: np.ndarray, cat_m: np.ndarray,
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Refit on every matched star and match again until the matched set stops
        changing (it may grow, or keep its size with other pairs; it never shrinks): a
        compact hypothesis leaves stars far from it unmatched at first, and a pair matched
        under the first attitude can belong to a neighbour under the refined one.

        When a plain refit changes nothing, the matches within ``CAPTURE`` match radii are
        refitted once, kept only if they then match more stars at the match radius: a
        hypothesis with one star a few pixels off, far from the others, can still pass
        (the stars near the others confirm it) with the attitude turned so that the rest
        of the frame lies beyond the match radius, where a plain refit never sees it.

        ``cat_m`` must be rows of the current cone (as :meth:`match` returns them).
        Returns the matches and the attitude fitted to them."""
        obs_m, cat_m, matrix = self._refine_on_cone(obs_m, cat_m)
        if not self.fixed and float(matrix[:, 2] @ self.boresight) < self.margin_cos:
            # Moved beyond the cone's margin (never by arcseconds): once more on a fresh cone.
            obs_m, cat_m, _ = self.match(matrix)
            obs_m, cat_m, matrix = self._refine_on_cone(obs_m, cat_m)
        return obs_m, cat_m, matrix

    def _refine_on_cone(self, obs_m: np.ndarray, cat_m: np.ndarray,
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        pos = np.searchsorted(self.rows, cat_m)
        obs_m, pos, matrix = kern.refine(self.obs_vectors, self.ox, self.oy, self.vectors,
                                         self.geometry, self.radius_px, CAPTURE,
                                         np.asarray(obs_m, np.int64), pos, MAX_REFINEMENTS)
        return obs_m, self.rows[pos], matrix

    def accept(self, obs_m: np.ndarray, cat_m: np.ndarray, label_params: tuple,
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """:meth:`refine`, the final labelling at the refined attitude and the attitude
        refitted to the labels, in one compiled call (``label_params``:
        :func:`startrack.verify._labelling.kernel_params`). Returns (obs_index, cat_index, matrix),
        or None when the refinement moved the boresight beyond the cone's margin (never by
        arcseconds): the caller then takes the steps one by one on a fresh cone."""
        pos = np.searchsorted(self.rows, cat_m)
        mags = np.ascontiguousarray(self.database.catalog.mag[self.rows], dtype=np.float64)
        obs_i, pos_i, refined, final = kern.refine_and_label(
            self.obs_vectors, self.ox, self.oy, self.vectors, mags, self.geometry,
            self.radius_px, CAPTURE, np.asarray(obs_m, np.int64), pos, MAX_REFINEMENTS,
            *label_params)
        if not self.fixed and float(refined[:, 2] @ self.boresight) < self.margin_cos:
            return None
        return obs_i, self.rows[pos_i], final
