"""The Tycho-2 sky, read from astrometry.net's index files and cached as arrays.

An index file (``index-tycho2-*.fits`` or ``index-41xx*.fits``, Debian's
``astrometry-data-tycho2-*`` packages) holds its stars as a kd-tree: the table
``kdtree_data_stars`` has three unsigned 32-bit integers per star, the unit vector
quantised over the box in ``kdtree_range_stars`` (three lower bounds, three upper bounds
and the scale, tree units per data unit, as doubles); the tag-along table ``MAG_VT``
has the Tycho VT magnitude of each star in the same order. Positions are J2000 without
proper motions. Each file is a brightness-uniform subset of Tycho-2, so a star is in
several files: the union is deduplicated (stars within :data:`DEDUP_ARCSEC` are one).

``catalog_id``: a star that is a Hipparcos star (within :data:`HIP_MATCH_ARCSEC` of its
Hipparcos-2 place carried to J2000) keeps its HIP number; any other star's id encodes
its position, ``TYCHO_ID_BASE + round(ra * 36000) * 6480001 + round((dec + 90) * 36000)``
(RA and Dec in degrees, so 0.1 arcsec cells), which is the same whichever set of index
files holds the star.
"""

from __future__ import annotations

import math
import os
import re
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from startrack.errors import InputError
from startrack.io import cached_arrays
from startrack.sky._catalog import Catalog, radec_to_vectors, vectors_to_radec
from startrack.sky._hipparcos import CATALOG_EPOCH, hipparcos_arrays, propagate

FORMAT_VERSION = 2  # 2: stored brightest first, so that a load sorts nothing
TYCHO2_EPOCH = 2000.0
#: where Debian's packages put the index files, then astrometry.net's own default
DEFAULT_INDEX_DIRS = ("/usr/share/astrometry", "/usr/local/astrometry/data")
INDEX_DIR_ENV = "STARTRACK_INDEX_DIR"
LITTLE_ENDIAN, BIG_ENDIAN = "04:03:02:01", "01:02:03:04"  # astrometry.net's ENDIAN card
INDEX_NAME = re.compile(r"^index-(tycho2-\d+|41\d\d).*\.fits$")
DEDUP_ARCSEC = 1.0
HIP_MATCH_ARCSEC = 1.0
TYCHO_ID_BASE = 10**14
#: the Debian packages, deepest first: -07- (index 4107) holds nearly every star
DEBIAN_PACKAGES = ("astrometry-data-tycho2-07-littleendian",
                   "astrometry-data-tycho2-08-littleendian",
                   "astrometry-data-tycho2-09-littleendian",
                   "astrometry-data-tycho2-10-19-littleendian")
INSTALL_HINT = f"apt-get install {DEBIAN_PACKAGES[0]} (or: make astrometry)"

_index_dir_option: str | None = None


def set_index_dir(folder: str | os.PathLike | None) -> None:
    """The folder given by ``--index-dir`` (searched before ``$STARTRACK_INDEX_DIR``)."""
    global _index_dir_option
    _index_dir_option = None if folder is None else str(folder)


def index_dirs() -> list[Path]:
    """Where index files are looked for: ``--index-dir``, else ``$STARTRACK_INDEX_DIR``,
    else :data:`DEFAULT_INDEX_DIRS`."""
    chosen = _index_dir_option or os.environ.get(INDEX_DIR_ENV)
    return [Path(chosen)] if chosen else [Path(d) for d in DEFAULT_INDEX_DIRS]


def index_files() -> list[Path]:
    """The Tycho-2 index files of the first folder of :func:`index_dirs` that has any."""
    for folder in index_dirs():
        try:
            found = sorted(p for p in folder.iterdir() if INDEX_NAME.match(p.name) and p.is_file())
        except OSError:
            continue
        if found:
            return found
    return []


def tycho2_installed() -> bool:
    """Whether any Tycho-2 index file is where :func:`index_files` looks."""
    return bool(index_files())


def read_index_stars(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """(unit vectors N x 3, VT magnitudes) of one index file's star table."""
    from astropy.io import fits  # astropy: loaded only when a Tycho-2 index is read

    try:
        with fits.open(path, memmap=True) as hdus:
            tables = {str(h.columns.names[0]): h for h in hdus[1:]
                      if isinstance(h, fits.BinTableHDU) and h.columns.names}
            data, box = tables["kdtree_data_stars"], tables["kdtree_range_stars"]
            mag_hdu = tables["MAG_VT"]
            if data.header.get("KDT_DATA", "u32").strip() != "u32":
                raise InputError(f"{path}: star tree data type {data.header['KDT_DATA']!r} "
                                 "is not u32")
            endian = str(hdus[0].header.get("ENDIAN", LITTLE_ENDIAN)).strip()
            if endian not in (LITTLE_ENDIAN, BIG_ENDIAN):
                raise InputError(f"{path}: ENDIAN card {endian!r} is neither "
                                 f"{LITTLE_ENDIAN} nor {BIG_ENDIAN}")
            order = "<" if endian == LITTLE_ENDIAN else ">"
            # The tree columns are raw bytes to astropy ('12A'); their dtype is the tree's.
            codes = np.frombuffer(data.data.tobytes(), f"{order}u4").reshape(-1, 3)
            low_high_scale = np.frombuffer(box.data.tobytes(), f"{order}f8")
            mag = np.asarray(mag_hdu.data["MAG_VT"], dtype=np.float64)
    except KeyError as exc:
        raise InputError(f"{path}: not an astrometry.net index file (no {exc} table)") from None
    # ValueError, TypeError: a truncated or altered table whose bytes do not make whole
    # stars, or columns of the wrong kind
    except (OSError, ValueError, TypeError) as exc:
        raise InputError(f"{path}: cannot read the index file ({exc})") from None
    if len(codes) != len(mag) or len(low_high_scale) != 7:
        raise InputError(f"{path}: star table and magnitudes disagree in length")
    scale = low_high_scale[6]
    if not (np.isfinite(low_high_scale).all() and scale > 0):
        raise InputError(f"{path}: the star tree's box or scale is not a positive finite "
                         f"number (scale {scale!r})")
    vectors = low_high_scale[:3] + codes / low_high_scale[6]
    vectors /= np.linalg.norm(vectors, axis=1, keepdims=True)
    return vectors, np.round(mag, 3)


def position_ids(ra_deg: np.ndarray, dec_deg: np.ndarray) -> np.ndarray:
    """The position-coded ids of the module docstring."""
    ra_cell = np.round(np.asarray(ra_deg) * 36000.0).astype(np.int64) % 12_960_000
    dec_cell = np.round((np.asarray(dec_deg) + 90.0) * 36000.0).astype(np.int64)
    return TYCHO_ID_BASE + ra_cell * 6_480_001 + dec_cell


def _chord(arcsec: float) -> float:
    return 2.0 * math.sin(math.radians(arcsec / 3600.0) / 2.0)


def _hipparcos_numbers(vectors: np.ndarray) -> np.ndarray:
    """The HIP number of each star within HIP_MATCH_ARCSEC of a Hipparcos star at J2000,
    else 0 (0 everywhere when the Hipparcos catalog is not installed)."""
    hip_ids = np.zeros(len(vectors), np.int64)
    try:
        hip = hipparcos_arrays()
    except InputError:
        return hip_ids
    ra, dec = propagate(hip["ra_deg"], hip["dec_deg"], hip["pm_ra"], hip["pm_dec"],
                        TYCHO2_EPOCH - CATALOG_EPOCH)
    dist, near = cKDTree(vectors).query(radec_to_vectors(ra, dec),
                                        distance_upper_bound=_chord(HIP_MATCH_ARCSEC))
    hit = np.isfinite(dist)
    # two Hipparcos entries on one Tycho star (a close pair): the first keeps it
    rows, first = np.unique(near[hit], return_index=True)
    hip_ids[rows] = hip["ids"][hit][first]
    return hip_ids


def parse_index_files(files: list[Path]) -> dict[str, np.ndarray]:
    """The deduplicated union of ``files``' stars: ids, J2000 RA/Dec, VT."""
    files = sorted(files, key=lambda p: -p.stat().st_size)  # the deepest file first
    vectors, mag = read_index_stars(files[0])
    for path in files[1:]:
        more_v, more_mag = read_index_stars(path)
        dist, _ = cKDTree(vectors).query(more_v, distance_upper_bound=_chord(DEDUP_ARCSEC))
        new = ~np.isfinite(dist)
        vectors = np.concatenate([vectors, more_v[new]])
        mag = np.concatenate([mag, more_mag[new]])
    ra, dec = vectors_to_radec(vectors)
    hip = _hipparcos_numbers(vectors)
    ids = np.where(hip > 0, hip, position_ids(ra, dec))
    order = np.argsort(mag, kind="stable")  # brightest first, as a Catalog holds them
    return {"ids": ids[order], "ra_deg": ra[order], "dec_deg": dec[order], "mag": mag[order]}


def tycho2_arrays(files: list[Path] | None = None) -> dict[str, np.ndarray]:
    """The parsed stars of ``files`` (default: :func:`index_files`), from the cache when
    none of the files changed."""
    files = index_files() if files is None else [Path(f) for f in files]
    if not files:
        where = ", ".join(str(d) for d in index_dirs())
        raise InputError(f"sky: no Tycho-2 index file (index-tycho2-*.fits) in {where}; "
                         f"{INSTALL_HINT}, or give --index-dir DIR")
    key = []
    for path in files:
        try:
            st = path.stat()
        except OSError as exc:
            raise InputError(f"{path}: cannot read the index file ({exc.strerror})") from None
        key.append([str(path.resolve()), st.st_size, st.st_mtime_ns])
    return cached_arrays("tycho2", {"files": key, "format": FORMAT_VERSION},
                         lambda: parse_index_files(files))


def load_tycho2() -> Catalog:
    """Every Tycho-2 star of the installed index files, J2000, VT magnitudes."""
    arrays = tycho2_arrays()
    return Catalog(ids=arrays["ids"], ra_deg=arrays["ra_deg"], dec_deg=arrays["dec_deg"],
                   mag=arrays["mag"], source={"sky": "tycho2", "epoch": TYCHO2_EPOCH})

__all__ = [
    "DEBIAN_PACKAGES", "DEDUP_ARCSEC", "DEFAULT_INDEX_DIRS", "FORMAT_VERSION",
    "HIP_MATCH_ARCSEC", "INDEX_DIR_ENV", "INDEX_NAME", "INSTALL_HINT", "TYCHO2_EPOCH",
    "TYCHO_ID_BASE", "index_dirs", "index_files", "load_tycho2", "parse_index_files",
    "position_ids", "read_index_stars", "set_index_dir", "tycho2_arrays", "tycho2_installed",
]
