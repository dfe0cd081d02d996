"""astrometry.net's ``solve-field`` as a matcher: the peer solves the frame's centroid
list, our verification judges its answer like every other method's.

The centroids go to ``solve-field`` as an xylist (a FITS table X, Y, FLUX; FITS pixels,
so the top-left pixel's centre is (1, 1): ours plus one), brightest first, with the image
size and the scale range ``--scale-units degwidth`` from the FOV the other methods are
told (``scale_tolerance`` either side). Its index files are the Tycho-2 ones the tycho2 sky
reads (startrack.sky._tycho2: ``--index-dir``, ``$STARTRACK_INDEX_DIR`` or the Debian
folders), listed in a config file of its own. Its answer is read from the ``.corr`` file
(each matched field star with the index star it was matched to): the field stars are our
centroids, the index stars are named by our catalog's star within
:data:`IDENTITY_ARCSEC`, and the matched pairs become hypotheses for our verification.
The time is the wall time of the ``solve-field`` process (it loads its index files each
run, as a user's call does).
"""

from __future__ import annotations

import shutil
import subprocess
import tempfile
import time
import warnings
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from startrack.attitude import to_quaternion
from startrack.errors import InputError
from startrack.match_records import Hypothesis, MatchDiagnostics, Observation
from startrack.matchers._base import register
from startrack.matchers._shared.peer import PeerMatcher, PeerSettings, positions_to_indices
from startrack.sky import index_files, radec_to_vectors

#: a star of astrometry.net's index and one of our catalog closer than this are one star
IDENTITY_ARCSEC = 3.0
INSTALL = ("astrometry needs astrometry.net's solve-field and its Tycho-2 index files: "
           "apt-get install astrometry.net astrometry-data-tycho2-07-littleendian "
           "(or: make astrometry)")


@dataclass(frozen=True)
class FieldSolution:
    """What one ``solve-field`` run matched: field pixels (ours, 0-based) and the index
    stars' ICRS unit vectors, row for row; empty when it did not solve."""

    x: np.ndarray
    y: np.ndarray
    vectors: np.ndarray
    wall_ms: float
    rotation: Rotation | None = None  # the solved WCS as our attitude (camera -> ICRS)

    @property
    def solved(self) -> bool:
        return len(self.x) > 0


def solve_field_available() -> bool:
    return shutil.which("solve-field") is not None


def _index_config(folder: Path) -> Path:
    """A ``--config`` file listing the index files of the tycho2 sky's folder."""
    files = index_files()
    if not solve_field_available() or not files:
        raise InputError(INSTALL)
    cfg = folder / "astrometry.cfg"
    cfg.write_text("inparallel\n" + "".join(f"index {p}\n" for p in files))
    return cfg


def write_xylist(path: Path, x: np.ndarray, y: np.ndarray, flux: np.ndarray) -> None:
    """Our centroids (0-based pixels) as a FITS xylist (1-based X, Y and FLUX)."""
    from astropy.io import fits  # astropy: only when astrometry.net runs

    cols = [fits.Column(name="X", format="D", array=np.asarray(x, float) + 1.0),
            fits.Column(name="Y", format="D", array=np.asarray(y, float) + 1.0),
            fits.Column(name="FLUX", format="D", array=np.asarray(flux, float))]
    fits.HDUList([fits.PrimaryHDU(), fits.BinTableHDU.from_columns(cols)]).writeto(path)


def read_corr(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(field x, field y in our 0-based pixels, index star unit vectors) of a .corr file."""
    from astropy.io import fits  # astropy: only when astrometry.net runs

    with fits.open(path) as hdus:
        t = hdus[1].data
        return (np.asarray(t["field_x"], float) - 1.0, np.asarray(t["field_y"], float) - 1.0,
                radec_to_vectors(np.asarray(t["index_ra"], float),
                                 np.asarray(t["index_dec"], float)))


def wcs_attitude(path: Path) -> Rotation | None:
    """Our attitude from a solved ``.wcs`` whose reference pixel is the image centre
    (``--crpix-center``): the boresight is CRVAL, and the CD matrix's columns are the
    directions of +x and +y there in (east, north); None when it is missing or mirrored."""
    from astropy.io import fits  # astropy: only when astrometry.net runs
    from astropy.wcs import WCS  # astropy: as above

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # astrometry.net's headers draw FITSFixed notes
            w = WCS(fits.getheader(path))
        cd = w.pixel_scale_matrix  # CD, or PC x CDELT
        crval = w.wcs.crval
    except (OSError, ValueError):
        return None
    ra, dec = np.radians(crval)
    boresight = radec_to_vectors(crval[0], crval[1])
    east = np.array([-np.sin(ra), np.cos(ra), 0.0])
    north = np.array([-np.sin(dec) * np.cos(ra), -np.sin(dec) * np.sin(ra), np.cos(dec)])
    x_axis = cd[0, 0] * east + cd[1, 0] * north
    y_axis = cd[0, 1] * east + cd[1, 1] * north
    if np.cross(x_axis, y_axis) @ boresight <= 0:  # a mirrored image: no attitude
        return None
    # the nearest rotation to (x, y, boresight) as columns (camera -> ICRS)
    u, _, vt = np.linalg.svd(np.column_stack([x_axis / np.linalg.norm(x_axis),
                                              y_axis / np.linalg.norm(y_axis), boresight]))
    return Rotation.from_matrix(u @ vt)


def solve_field(x: np.ndarray, y: np.ndarray, flux: np.ndarray, size: tuple[int, int],
                scale_deg: tuple[float, float] | None, cpulimit_s: float,
                work: Path) -> FieldSolution:
    """Run ``solve-field`` on one centroid list in the folder ``work`` (its config made by
    :func:`_index_config` there first); ``scale_deg`` (low, high) image widths or None."""
    cfg = work / "astrometry.cfg"
    if not cfg.exists():
        _index_config(work)
    run = Path(tempfile.mkdtemp(dir=work))
    xy = run / "field.xyls"
    write_xylist(xy, x, y, flux)
    cmd = ["solve-field", str(xy), "--config", str(cfg), "--dir", str(run),
           "--width", str(size[0]), "--height", str(size[1]),
           "--x-column", "X", "--y-column", "Y", "--sort-column", "FLUX",
           "--no-plots", "--overwrite", "--no-remove-lines", "--uniformize", "0",
           "--crpix-center",
           "--cpulimit", str(max(1, int(np.ceil(cpulimit_s)))),
           "--new-fits", "none", "--rdls", "none", "--match", "none", "--index-xyls", "none",
           "--temp-axy"]
    if scale_deg is not None:
        cmd += ["--scale-units", "degwidth", "--scale-low", f"{scale_deg[0]:.6f}",
                "--scale-high", f"{scale_deg[1]:.6f}"]
    t0 = time.perf_counter()
    done = subprocess.run(cmd, capture_output=True, text=True, check=False)
    wall_ms = (time.perf_counter() - t0) * 1000.0
    corr = run / "field.corr"
    try:
        if done.returncode != 0 or not corr.exists():
            return FieldSolution(np.empty(0), np.empty(0), np.empty((0, 3)), wall_ms)
        fx, fy, vectors = read_corr(corr)
        return FieldSolution(fx, fy, vectors, wall_ms, wcs_attitude(run / "field.wcs"))
    finally:
        shutil.rmtree(run, ignore_errors=True)


@dataclass(frozen=True)
class SolveFieldSettings(PeerSettings):
    """``scale_tolerance``: the image width solve-field may try, as a fraction above or
    below the camera's; ``cpulimit_s``: its CPU time per frame."""

    scale_tolerance: float = 0.05
    cpulimit_s: float = 30.0


@register
class AstrometryMatcher(PeerMatcher):
    """astrometry.net's ``solve-field`` (quads of 4 stars, Tycho-2 index files)."""

    name = "astrometry"
    description = "peer: astrometry.net solve-field on the centroid list (Tycho-2 index)"

    settings_type = SolveFieldSettings
    _work: tempfile.TemporaryDirectory | None = None  # solve-field's config, by prepare
    _tree: cKDTree | None = None  # our catalog's vectors, to name the stars it matched

    def prepare(self) -> None:
        if self._work is not None:
            return
        work = tempfile.TemporaryDirectory(prefix="startrack-astrometry-")
        _index_config(Path(work.name))  # raises the install hint when it is missing
        self._work = work
        self._tree = cKDTree(self.database.catalog.vectors)

    def hypotheses(self, obs: Observation, diag: MatchDiagnostics,
                   screen_rad: float | None = None) -> Iterator[Hypothesis]:
        self.prepare()
        cam = obs.camera
        x, y = cam.ideal_pixels(obs.x, obs.y)  # the peer knows no lens distortion
        flux = obs.flux if obs.flux is not None else np.arange(len(x), 0, -1, dtype=float)
        tol = self.settings.scale_tolerance
        found = solve_field(x, y, flux, (cam.width, cam.height),
                            (cam.fov_deg * (1.0 - tol), cam.fov_deg * (1.0 + tol)),
                            self.settings.cpulimit_s, Path(self._work.name))
        diag.method_ms = found.wall_ms
        diag.extra["peer_status"] = "solved" if found.solved else "not solved"
        if not found.solved:
            return
        diag.candidates += 1
        diag.extra["peer_matches"] = len(found.x)
        obs_index = positions_to_indices(np.column_stack([x, y]),
                                         np.column_stack([found.x, found.y]), tol=0.01)
        chord = 2.0 * np.sin(np.radians(IDENTITY_ARCSEC / 3600.0) / 2.0)
        dist, rows = self._tree.query(found.vectors, distance_upper_bound=chord)
        cat_index = np.where(np.isfinite(dist), rows, -1)
        if found.rotation is not None:
            diag.extra["peer_quaternion"] = to_quaternion(found.rotation)
        yield from self.grouped_hypotheses(obs_index, cat_index)

__all__ = [
    "AstrometryMatcher", "FieldSolution", "IDENTITY_ARCSEC", "INSTALL", "read_corr",
    "solve_field", "solve_field_available", "wcs_attitude", "write_xylist",
]
