"""tetra3 (the ``cedar-solve`` package) as a matcher: the peer solves, our verification
judges its answer like every other method's.

Conventions, from tetra3's source (cedar-solve 0.5): centroids are (y, x) = (row, column)
with (0, 0) the top-left *corner* of the image, so the top-left pixel's centre is (0.5, 0.5)
and the optical axis is at (height / 2, width / 2). Its camera frame is (i, j, k) =
(boresight, towards -x, towards -y); its RA/Dec/Roll decode a matrix whose rows are those
axes in ICRS, with roll = atan2(j_z, k_z), i.e. positive when north is counter-clockwise
from image up: our roll (north towards east to up) is minus its roll.
"""

from __future__ import annotations

import logging
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from startrack.attitude import from_radec_roll, to_quaternion
from startrack.io import cached_file
from startrack.match_records import Hypothesis, MatchDiagnostics, Observation
from startrack.matchers._base import register
from startrack.matchers._shared.peer import (
    EdgeRatioSolve,
    PeerMatcher,
    import_peer,
    peer_version,
    positions_to_indices,
    write_hip_main,
)


def tetra3_centroids(obs: Observation) -> np.ndarray:
    """Our centroids as tetra3's (y, x): corner origin, optical axis at the image centre."""
    cam = obs.camera
    x, y = cam.ideal_pixels(obs.x, obs.y)  # the peer knows no lens distortion
    return np.column_stack([y - cam.cy + cam.height / 2.0, x - cam.cx + cam.width / 2.0])


def attitude_from_tetra3(ra_deg: float, dec_deg: float, roll_deg: float):
    """tetra3's RA/Dec/Roll as our attitude (camera -> ICRS Rotation)."""
    return from_radec_roll(ra_deg, dec_deg, -roll_deg)


#: tetra3's solve_from_centroids keywords where they differ from :class:`EdgeRatioSolve`'s
TETRA3_NAMES = {"fov_max_error_deg": "fov_max_error", "solve_timeout_ms": "solve_timeout"}


@register
class Tetra3Matcher(PeerMatcher):
    """tetra3's 4-star edge-ratio hash, on a database built from our catalog."""

    name = "tetra3"
    description = "peer: tetra3 (cedar-solve), 4-star edge-ratio pattern hash"

    settings_type = EdgeRatioSolve

    @property
    def solve_kwargs(self) -> dict:
        """The settings under tetra3's names for them."""
        return {TETRA3_NAMES.get(key, key): value
                for key, value in self.settings.as_dict().items()}

    def prepare(self) -> None:
        if self._solver is not None:
            return
        tetra3 = import_peer("tetra3", self.name)
        logger = logging.getLogger("tetra3.Tetra3")
        if not logger.handlers:  # else tetra3 adds a console handler logging at INFO
            logger.addHandler(logging.NullHandler())
        logger.setLevel(logging.WARNING)
        catalog, camera = self.database.catalog, self.database.camera
        params = {"catalog": catalog.fingerprint(), "fov": round(camera.fov_deg, 9),
                  "peer": peer_version("cedar-solve"), **self.db_params}

        def build(path: Path) -> None:
            # tetra3 knows a catalog's format by its file name only.
            with tempfile.TemporaryDirectory(dir=path.parent) as tmp:
                star_file = Path(tmp) / "hip_main.dat"
                write_hip_main(catalog, star_file)
                t3 = tetra3.Tetra3(load_database=None)
                t3.generate_database(max_fov=camera.fov_deg, star_catalog=str(star_file),
                                     star_max_magnitude=float(catalog.mag.max()) + 1e-3,
                                     epoch_proper_motion=None, **self.db_params)
                t3.save_database(path)

        path = cached_file("tetra3", params, ".npz", build)
        self._solver = tetra3.Tetra3(load_database=path)

    def hypotheses(self, obs: Observation, diag: MatchDiagnostics,
                   screen_rad: float | None = None) -> Iterator[Hypothesis]:
        self.prepare()
        cam = obs.camera
        centroids = tetra3_centroids(obs)
        t0 = time.perf_counter()
        result = self._solver.solve_from_centroids(
            centroids, (cam.height, cam.width), fov_estimate=cam.fov_deg, distortion=None,
            return_matches=True, **self.solve_kwargs)
        diag.method_ms = (time.perf_counter() - t0) * 1000.0
        diag.extra["peer_status"] = int(result.get("status", 0))
        if result.get("RA") is None:
            return
        diag.candidates += 1
        rotation = attitude_from_tetra3(result["RA"], result["Dec"], result["Roll"])
        diag.extra["peer_quaternion"] = to_quaternion(rotation)
        diag.extra["peer_matches"] = int(result["Matches"])
        obs_index = positions_to_indices(centroids, np.asarray(result["matched_centroids"]))
        yield from self.peer_hypotheses(obs_index, result["matched_catID"])

__all__ = ["Tetra3Matcher", "attitude_from_tetra3", "tetra3_centroids"]
