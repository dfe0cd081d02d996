"""tetra3rs (a Rust tetra3) as a matcher: the peer solves, our verification judges its
answer like every other method's.

Conventions, from tetra3rs's documentation and source (0.14): centroids are (x, y) in
pixels with the origin at the optical axis (the image centre, plus ``crpix``), +x right,
+y down; so ours shift by the principal point (cx, cy) and nothing else. Its camera frame
is (+x right, +y down, +z boresight), ours, and ``rotation_matrix_icrs_to_camera`` is the
transpose of our attitude. ``parity_flip`` would mean a mirrored image; our frames never
are, so its rotation is then not reported as an attitude.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from startrack.attitude import to_quaternion
from startrack.io import cached_file
from startrack.match_records import Hypothesis, MatchDiagnostics, Observation
from startrack.matchers._base import register
from startrack.matchers._shared.peer import (
    EdgeRatioSolve,
    PeerMatcher,
    import_peer,
    peer_version,
    write_gaia_binary,
)


def tetra3rs_centroids(obs: Observation) -> np.ndarray:
    """Our centroids as tetra3rs's (x, y), origin at the optical axis."""
    x, y = obs.camera.ideal_pixels(obs.x, obs.y)  # the peer knows no lens distortion
    return np.column_stack([x - obs.camera.cx, y - obs.camera.cy])


def attitude_from_tetra3rs(icrs_to_camera: np.ndarray) -> Rotation:
    """tetra3rs's ICRS -> camera matrix as our attitude (camera -> ICRS)."""
    return Rotation.from_matrix(np.asarray(icrs_to_camera, dtype=np.float64).T)


@dataclass(frozen=True)
class Tetra3rsSolve(EdgeRatioSolve):
    """tetra3rs's defaults: tetra3's, with a stricter false-match probability."""

    match_threshold: float = 1e-5


@register
class Tetra3rsMatcher(PeerMatcher):
    """tetra3rs's 4-star edge-ratio hash, on a database built from our catalog."""

    name = "tetra3rs"
    description = "peer: tetra3rs (Rust tetra3), 4-star edge-ratio pattern hash"

    settings_type = Tetra3rsSolve
    _camera_model = None  # (focal length and size, the peer's CameraModel) of the last frame

    @property
    def solve_kwargs(self) -> dict:
        """The settings as tetra3rs's keywords (its timeout a whole number of ms)."""
        settings = self.settings.as_dict()
        return {**settings, "solve_timeout_ms": int(settings["solve_timeout_ms"])}

    def prepare(self) -> None:
        if self._solver is not None:
            return
        tetra3rs = import_peer("tetra3rs", self.name)
        catalog, camera = self.database.catalog, self.database.camera
        params = {"catalog": catalog.fingerprint(), "fov": round(camera.fov_deg, 9),
                  "peer": peer_version("tetra3rs"), **self.db_params}

        def build(path: Path) -> None:
            star_file = path.with_name(path.name + "-catalog.bin")
            try:
                write_gaia_binary(catalog, star_file)
                db = tetra3rs.SolverDatabase.generate_from_gaia(
                    str(star_file), max_fov_deg=camera.fov_deg,
                    star_max_magnitude=float(catalog.mag.max()) + 1e-3,
                    epoch_proper_motion_year=None, **self.db_params)
                db.save_to_file(str(path))
            finally:
                star_file.unlink(missing_ok=True)

        path = cached_file("tetra3rs", params, ".bin", build)
        self._solver = tetra3rs.SolverDatabase.load_from_file(str(path))
        self._tetra3rs = tetra3rs

    def _camera_for(self, obs: Observation):
        cam = obs.camera
        key = (cam.f_px, cam.width, cam.height)
        if self._camera_model is None or self._camera_model[0] != key:
            model = self._tetra3rs.CameraModel(cam.f_px, cam.width, cam.height)
            self._camera_model = (key, model)
        return self._camera_model[1]

    def hypotheses(self, obs: Observation, diag: MatchDiagnostics,
                   screen_rad: float | None = None) -> Iterator[Hypothesis]:
        self.prepare()
        centroids = tetra3rs_centroids(obs)
        model = self._camera_for(obs)
        t0 = time.perf_counter()
        result = self._solver.solve_from_centroids(centroids, camera_model=model,
                                                   **self.solve_kwargs)
        diag.method_ms = (time.perf_counter() - t0) * 1000.0
        diag.extra["peer_status"] = str(result.status)
        if not result:
            return
        diag.candidates += 1
        diag.extra["peer_matches"] = int(result.num_matches)
        diag.extra["parity_flip"] = bool(result.parity_flip)
        if not result.parity_flip:
            rotation = attitude_from_tetra3rs(result.rotation_matrix_icrs_to_camera)
            diag.extra["peer_quaternion"] = to_quaternion(rotation)
        obs_index = np.asarray(result.matched_centroids, dtype=np.int64)
        yield from self.peer_hypotheses(obs_index, result.matched_catalog_ids)

__all__ = ["Tetra3rsMatcher", "attitude_from_tetra3rs", "tetra3rs_centroids"]
