"""tetra3, tetra3rs and astrometry.net for scripts/bench/bench_blind_peers.py: databases over a
range of FOVs built from the frames' catalog (cached on disk; astrometry.net uses its own
Tycho-2 index files), and one solve call scored the same way as startrack's: (rotation,
observed rows, catalog directions of the named stars) or None.
"""

from __future__ import annotations

import logging
import math
import tempfile
import time
from pathlib import Path

import numpy as np

from startrack.errors import InputError
from startrack.io import cached_file
from startrack.matchers import (
    INSTALL,
    attitude_from_tetra3,
    attitude_from_tetra3rs,
    positions_to_indices,
    solve_field,
    solve_field_available,
    tetra3_centroids,
    tetra3rs_centroids,
    write_gaia_binary,
    write_hip_main,
)


def ranges(fov: float, search: float, tolerance: float, span: float) -> dict:
    """The databases' FOV ranges: "fov" spans every estimate's searched range, "blind"
    the no-FOV span about the true FOV."""
    return {"fov": (fov * (1 - tolerance) * (1 - search), fov * (1 + tolerance) * (1 + search)),
            "blind": (fov / span, fov * span)}


class _Peer:
    def __init__(self, catalog, camera, fov, search, tolerance, span, timeout_ms) -> None:
        self.catalog, self.camera, self.search = catalog, camera, search
        self.timeout_ms = float(timeout_ms)
        self.ranges = ranges(fov, search, tolerance, span)
        self._db: dict[str, object] = {}

    def db(self, mode: str):
        if mode not in self._db:
            lo, hi = self.ranges[mode]
            self._db[mode] = self.build(lo, hi)
        return self._db[mode]

    def named(self, obs_index: np.ndarray, ids: np.ndarray):
        """Observed rows and catalog directions of the peer's named stars (an id it names
        that is not in the catalog is a wrong star: a direction no true star has)."""
        rows = self.catalog.index_of(np.asarray(ids, dtype=np.int64))
        vectors = np.where((rows >= 0)[:, None], self.catalog.vectors[np.maximum(rows, 0)],
                           -self.catalog.vectors[np.maximum(rows, 0)])
        keep = obs_index >= 0
        return obs_index[keep], vectors[keep]


class Tetra3(_Peer):
    def build(self, lo: float, hi: float):
        import tetra3

        logger = logging.getLogger("tetra3.Tetra3")
        if not logger.handlers:  # else tetra3 adds a console handler logging at INFO
            logger.addHandler(logging.NullHandler())
        logger.setLevel(logging.WARNING)
        catalog = self.catalog

        def make(path: Path) -> None:
            with tempfile.TemporaryDirectory(dir=path.parent) as tmp:
                star_file = Path(tmp) / "hip_main.dat"
                write_hip_main(catalog, star_file)
                t3 = tetra3.Tetra3(load_database=None)
                t3.generate_database(max_fov=hi, min_fov=lo, star_catalog=str(star_file),
                                     star_max_magnitude=float(catalog.mag.max()) + 1e-3,
                                     epoch_proper_motion=None)
                t3.save_database(path)

        params = {"catalog": catalog.fingerprint(), "lo": round(lo, 6), "hi": round(hi, 6)}
        return tetra3.Tetra3(load_database=cached_file("tetra3-range", params, ".npz", make))

    def solve(self, frame, est: float | None):
        solver = self.db("blind" if est is None else "fov")
        centroids = tetra3_centroids(frame.obs)
        t0 = time.perf_counter()
        r = solver.solve_from_centroids(
            centroids, (self.camera.height, self.camera.width), fov_estimate=est,
            fov_max_error=None if est is None else self.search * est, distortion=None,
            return_matches=True, solve_timeout=self.timeout_ms)
        ms = (time.perf_counter() - t0) * 1000.0
        if r.get("RA") is None:
            return None, ms
        rot = attitude_from_tetra3(r["RA"], r["Dec"], r["Roll"])
        obs_index = positions_to_indices(centroids, np.asarray(r["matched_centroids"]))
        return (rot, *self.named(obs_index, r["matched_catID"])), ms


class Tetra3rs(_Peer):
    def build(self, lo: float, hi: float):
        import tetra3rs

        catalog = self.catalog

        def make(path: Path) -> None:
            star_file = path.with_name(path.name + "-catalog.bin")
            try:
                write_gaia_binary(catalog, star_file)
                db = tetra3rs.SolverDatabase.generate_from_gaia(
                    str(star_file), max_fov_deg=hi, min_fov_deg=lo,
                    star_max_magnitude=float(catalog.mag.max()) + 1e-3,
                    epoch_proper_motion_year=None)
                db.save_to_file(str(path))
            finally:
                star_file.unlink(missing_ok=True)

        params = {"catalog": catalog.fingerprint(), "lo": round(lo, 6), "hi": round(hi, 6)}
        path = cached_file("tetra3rs-range", params, ".bin", make)
        return tetra3rs.SolverDatabase.load_from_file(str(path))

    def solve(self, frame, est: float | None):
        solver = self.db("blind" if est is None else "fov")
        if est is None:  # no unknown-FOV mode: the centre of its range, the range as error
            lo, hi = self.ranges["blind"]
            est = math.sqrt(lo * hi)
            max_error = max(hi - est, est - lo)
        else:
            max_error = self.search * est
        t0 = time.perf_counter()
        r = solver.solve_from_centroids(
            tetra3rs_centroids(frame.obs), fov_estimate_deg=est, fov_max_error_deg=max_error,
            image_width=self.camera.width, image_height=self.camera.height,
            solve_timeout_ms=int(self.timeout_ms))
        ms = (time.perf_counter() - t0) * 1000.0
        if not r or r.parity_flip:
            return None, ms
        rot = attitude_from_tetra3rs(r.rotation_matrix_icrs_to_camera)
        obs_index = np.asarray(r.matched_centroids, dtype=np.int64)
        return (rot, *self.named(obs_index, r.matched_catalog_ids)), ms


class Astrometry(_Peer):
    """solve-field on the centroid list: the searched FOV range as ``--scale-low/high``
    (degwidth); with no FOV no scale at all, its own blind mode over every index file.
    The named stars are its index stars' directions; the attitude is its WCS's
    (startrack.matchers._astrometry.wcs_attitude)."""

    def __init__(self, *args) -> None:
        super().__init__(*args)
        from startrack.sky import index_files

        if not solve_field_available() or not index_files():
            raise InputError(INSTALL)
        self.work = tempfile.TemporaryDirectory(prefix="bench-astrometry-")
        # untimed warm-up on junk: its index files read into the page cache once
        junk = np.random.default_rng(0).uniform(0, 100, (12, 2))
        solve_field(junk[:, 0], junk[:, 1], np.arange(12.0, 0, -1), (100, 100), (1.0, 2.0),
                    1.0, Path(self.work.name))

    def solve(self, frame, est: float | None):
        obs = frame.obs
        x, y = obs.camera.ideal_pixels(obs.x, obs.y)  # it knows no lens distortion
        flux = np.arange(len(x), 0, -1, dtype=float)  # brightest first, as observed
        scale = None if est is None else (est * (1 - self.search), est * (1 + self.search))
        found = solve_field(x, y, flux, (self.camera.width, self.camera.height), scale,
                            self.timeout_ms / 1000.0, Path(self.work.name))
        if not found.solved or found.rotation is None:
            return None, found.wall_ms
        obs_index = positions_to_indices(np.column_stack([x, y]),
                                         np.column_stack([found.x, found.y]), tol=0.01)
        keep = obs_index >= 0
        return (found.rotation, obs_index[keep], found.vectors[keep]), found.wall_ms


PEERS = {"tetra3": Tetra3, "tetra3rs": Tetra3rs, "astrometry": Astrometry}
