"""The user's own catalog (``--sky FILE``): a CSV, FITS table or Parquet file of stars,
every row checked, cached by the file's content.

Columns (any other is ignored; names are matched without regard to case): ``ra``,
``dec`` (degrees, ICRS), ``mag``; optional ``pm_ra`` (mas/yr, with cos dec), ``pm_dec``
(mas/yr), ``epoch`` (Julian year of the row's position, default 2000.0) and ``id``
(integer, default the 1-based row number). Rows are numbered from 1, the first row after
a CSV's header; a bad row is an :class:`InputError` naming the file and the row.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xxhash

from startrack.errors import InputError
from startrack.io import cached_arrays
from startrack.sky._catalog import BadId, Catalog, exact_ids
from startrack.sky._hipparcos import julian_year, propagate

#: 2: ids parsed as exact 64-bit integers (1 passed them through float64)
FORMAT_VERSION = 2
SUFFIXES = (".csv", ".fits", ".fit", ".parquet")
REQUIRED = ("ra", "dec", "mag")
OPTIONAL = {"pm_ra": 0.0, "pm_dec": 0.0, "epoch": 2000.0}
#: (column, lowest, highest) a value may take
RANGES = (("ra", -360.0, 360.0), ("dec", -90.0, 90.0), ("mag", -30.0, 40.0),
          ("epoch", 1000.0, 3000.0),
          # ten times Barnard's star's 10.4"/yr: a millennium moves a star at most ~30 deg
          ("pm_ra", -1e5, 1e5), ("pm_dec", -1e5, 1e5))


def is_catalog_path(text: str) -> bool:
    """Whether ``--sky TEXT`` names a catalog file rather than a sky kind."""
    return Path(text).suffix.lower() in SUFFIXES


def _read_table(path: Path) -> dict[str, np.ndarray]:
    """The file's columns (lower-case names) as arrays; unparsable cells become NaN."""
    import pandas as pd  # pandas: loaded only when a catalog file is read

    suffix = path.suffix.lower()
    try:
        if suffix == ".csv":
            frame = pd.read_csv(path, dtype=str, keep_default_na=False, skipinitialspace=True)
        elif suffix == ".parquet":
            try:
                import pyarrow  # noqa: F401  # pyarrow: optional, for Parquet only
            except ImportError:
                raise InputError(f"{path}: reading Parquet needs pyarrow (pip install "
                                 "pyarrow), or give the catalog as .csv or .fits") from None
            frame = pd.read_parquet(path)
        else:
            from astropy.table import Table  # astropy: only for a FITS catalog

            table = Table.read(path, format="fits")
            _check_units(path, table)
            frame = pd.DataFrame({name: np.asarray(table[name]) for name in table.colnames
                                  if table[name].ndim == 1})
    except InputError:
        raise
    except FileNotFoundError:
        raise InputError(f"{path}: catalog file not found") from None
    except Exception as exc:  # any parser's complaint: the file is not a table
        raise InputError(f"{path}: cannot read the catalog ({str(exc).splitlines()[0]})") \
            from None
    columns = {}
    for name in frame.columns:
        key = str(name).strip().lower()
        if key in (*REQUIRED, *OPTIONAL, "id") and key not in columns:
            columns[key] = frame[name].to_numpy()
            if suffix == ".parquet" and columns[key].dtype == object:
                columns[key] = _scalars(path, key, columns[key])
    return columns


def _scalars(path: Path, name: str, values: np.ndarray) -> np.ndarray:
    """A Parquet column of objects, refused when a cell is a list or struct (no number)."""
    bad = np.flatnonzero([np.ndim(v) != 0 or isinstance(v, dict) for v in values])
    if len(bad):
        raise InputError(f"{path}: row {int(bad[0]) + 1}: {name} holds a list or struct, "
                         "not a number")
    return values


def _check_units(path: Path, table) -> None:
    """Refuse a FITS catalog whose ra or dec column declares another unit than degrees
    (RA in hours would crowd the sky into 24 degrees: wrong stars, and a dense sky)."""
    for name in table.colnames:
        unit = table[name].unit
        if name.strip().lower() in ("ra", "dec") and unit is not None \
                and unit.to_string() not in ("deg", ""):
            raise InputError(f"{path}: column {name} is in {unit.to_string()!r} (TUNIT); "
                             "startrack reads ra and dec in degrees: convert the column")


def _numbers(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(float values, empty cells) of a column; a non-number is NaN and not empty."""
    import pandas as pd  # pandas: loaded only when a catalog file is read

    text = values.astype(str) if values.dtype == object else None
    empty = np.zeros(len(values), bool) if text is None else np.char.strip(
        text.astype("U")) == ""
    numbers = pd.to_numeric(pd.Series(values), errors="coerce")
    numbers = numbers.to_numpy(np.float64, copy=True)
    return numbers, empty


#: a catalog whose every ra lies in [0, 24] while its dec spans more than this many
#: degrees gives its ra in hours (a real field that wide is never 24 deg of ra only)
HOURS_DEC_SPAN_DEG = 90.0


def _refuse_hours(path: Path, ra: np.ndarray, dec: np.ndarray) -> None:
    """Refuse ra in hours: read as degrees it crowds the sky into 24 degrees (wrong
    stars, and a sky far denser than any real one)."""
    span = float(dec.max() - dec.min())
    if len(ra) >= 100 and ra.min() >= 0.0 and ra.max() <= 24.0 and span > HOURS_DEC_SPAN_DEG:
        raise InputError(f"{path}: every ra lies within 0 to 24 while dec spans {span:.0f} "
                         "deg: ra in hours? startrack reads ra in degrees (multiply by 15)")


def _fail(path: Path, row: int, message: str) -> InputError:
    return InputError(f"{path}: row {row + 1}: {message}")


def parse_catalog(path: Path) -> dict[str, np.ndarray]:
    """Checked arrays of a catalog file: ids, ra_deg, dec_deg, mag, pm_ra, pm_dec, epoch."""
    columns = _read_table(path)
    missing = [name for name in REQUIRED if name not in columns]
    if missing:
        raise InputError(f"{path}: missing column(s) {', '.join(missing)} (needs ra, dec, "
                         "mag; optional pm_ra, pm_dec, epoch, id)")
    n = len(columns["ra"])
    if n == 0:
        raise InputError(f"{path}: the catalog has no rows")
    values = {}
    for name in (*REQUIRED, *OPTIONAL):
        if name not in columns:
            values[name] = np.full(n, OPTIONAL[name])
            continue
        numbers, empty = _numbers(columns[name])
        if name in OPTIONAL:  # an empty optional cell takes the default
            numbers[empty] = OPTIONAL[name]
        bad = np.flatnonzero(~np.isfinite(numbers))
        if len(bad):
            cell = columns[name][bad[0]]
            raise _fail(path, bad[0], f"{name} {cell!r} is not a finite number")
        values[name] = numbers
    for name, low, high in RANGES:
        bad = np.flatnonzero((values[name] < low) | (values[name] > high))
        if len(bad):
            raise _fail(path, bad[0], f"{name} {values[name][bad[0]]:g} is outside "
                        f"[{low:g}, {high:g}]")
    _refuse_hours(path, values["ra"], values["dec"])
    ids = np.arange(1, n + 1, dtype=np.int64)
    if "id" in columns:
        try:
            ids = exact_ids(columns["id"])
        except BadId as exc:
            raise _fail(path, exc.row, str(exc)) from None
        order = np.argsort(ids, kind="stable")
        dup = np.flatnonzero(ids[order][1:] == ids[order][:-1])
        if len(dup):
            raise _fail(path, int(order[dup[0] + 1]), f"id {ids[order][dup[0]]} repeats an "
                        "earlier row's")
    return {"ids": ids, "ra_deg": values["ra"] % 360.0, "dec_deg": values["dec"],
            "mag": values["mag"], "pm_ra": values["pm_ra"], "pm_dec": values["pm_dec"],
            "epoch": values["epoch"]}


def content_hash(path: Path) -> str:
    """XXH3-128 of the file's bytes: the cache key of its parsed catalog."""
    digest = xxhash.xxh3_128()
    try:
        with open(path, "rb") as fh:
            while chunk := fh.read(1 << 22):
                digest.update(chunk)
    except FileNotFoundError:
        raise InputError(f"{path}: catalog file not found") from None
    except OSError as exc:
        raise InputError(f"{path}: cannot read the catalog ({exc.strerror})") from None
    return digest.hexdigest()


def catalog_arrays(path: str | Path) -> dict[str, np.ndarray]:
    """The checked arrays of ``path``, from the cache when a file of the same content was
    read before."""
    path = Path(path)
    if path.suffix.lower() not in SUFFIXES:
        raise InputError(f"{path}: a catalog file must be {', '.join(SUFFIXES)}")
    if path.exists() and not path.is_file():  # a device (/dev/zero) would be read forever
        raise InputError(f"{path}: not a regular file (a folder, pipe or device); a catalog "
                         "is a file")
    key = {"content": content_hash(path), "suffix": path.suffix.lower(),
           "format": FORMAT_VERSION}
    return cached_arrays("usersky", key, lambda: parse_catalog(path))


def load_user_catalog(path: str | Path, epoch: float | None = None) -> Catalog:
    """The catalog of ``path``; positions at each row's epoch, or moved by proper motion
    to ``epoch`` (Julian year) when given."""
    arrays = catalog_arrays(path)
    ra, dec = arrays["ra_deg"], arrays["dec_deg"]
    if epoch is not None:
        years = julian_year(epoch) - arrays["epoch"]
        ra, dec = propagate(ra, dec, arrays["pm_ra"], arrays["pm_dec"], years)
    return Catalog(ids=arrays["ids"], ra_deg=ra, dec_deg=dec, mag=arrays["mag"],
                   source={"sky": "file", "path": str(path), "epoch": epoch})

__all__ = [
    "FORMAT_VERSION", "OPTIONAL", "RANGES", "REQUIRED", "SUFFIXES", "catalog_arrays",
    "content_hash", "is_catalog_path", "load_user_catalog", "parse_catalog",
]
