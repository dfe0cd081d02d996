"""Reading and writing grey frames (PNG, TIFF, FITS) as 2-D numpy arrays; no algorithms.

Array convention: ``image[row, col]``, row 0 at the top (docs/conventions.md). FITS data is kept
in its stored array order (row 0 = first row in the file), so a frame written with
``write_fits`` reads back identically.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator, Mapping
from pathlib import Path

import numpy as np

from startrack.errors import InputError, InputFileNotFoundError
from startrack.io._headers import check_image_size, check_pixels
from startrack.io._writer import atomic_path

PNG_SUFFIXES = (".png",)
TIFF_SUFFIXES = (".tif", ".tiff")
FITS_SUFFIXES = (".fits", ".fit", ".fts")
_STRUCTURAL = {"SIMPLE", "BITPIX", "NAXIS", "NAXIS1", "NAXIS2", "EXTEND", "BZERO", "BSCALE"}
_CV2_SUFFIXES = PNG_SUFFIXES + TIFF_SUFFIXES + (".jpg", ".jpeg", ".bmp", ".pgm", ".pnm")


@contextlib.contextmanager
def _opencv_quiet() -> Iterator[None]:
    """Silence OpenCV's own logging where this build exposes it (not every 4.x does)."""
    import cv2  # cv2: OpenCV, loaded by the first image read

    logging = getattr(getattr(cv2, "utils", None), "logging", None)
    if logging is None:
        yield
        return
    level = logging.getLogLevel()
    logging.setLogLevel(logging.LOG_LEVEL_SILENT)
    try:
        yield
    finally:
        logging.setLogLevel(level)


def read_image(path: str | Path) -> np.ndarray:
    """Read a frame as a 2-D grey array (uint8, uint16 or float); colour is made grey.

    Raises InputError naming the file for a missing, unreadable, empty or non-2-D image,
    or an unsupported extension.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in _CV2_SUFFIXES + FITS_SUFFIXES:
        raise InputError(f"{path}: unsupported image type '{path.suffix or '(none)'}' "
                         f"(use PNG, TIFF or FITS)")
    if not path.exists():
        raise InputFileNotFoundError(f"{path}: no such file")
    if path.is_dir():
        raise InputError(f"{path}: is a directory, not an image")
    try:
        if suffix not in FITS_SUFFIXES:
            check_image_size(path)  # from the header: a huge frame is refused undecoded
        raw = _read_fits(path) if suffix in FITS_SUFFIXES else _read_raster(path, suffix)
    except OSError as exc:
        raise InputError(f"{path}: cannot read ({exc.strerror or exc})") from None
    return _as_grey_2d(raw, path)


def _read_raster(path: Path, suffix: str) -> np.ndarray:
    import cv2  # cv2: OpenCV, loaded by the first image read

    data = np.fromfile(path, dtype=np.uint8)
    if data.size == 0:
        raise InputError(f"{path}: empty file (0 bytes)")
    if suffix in TIFF_SUFFIXES:
        _reject_tiff_stack(path)
    # imdecode, not imread: no trouble with non-ASCII paths. OpenCV logs decoder errors
    # to stderr; the InputError below says it once, so silence them meanwhile.
    with _opencv_quiet():
        image = cv2.imdecode(data, cv2.IMREAD_UNCHANGED)
    if image is None and suffix in TIFF_SUFFIXES:
        image = _read_tiff_fallback(path)
    if image is None:
        raise InputError(f"{path}: not a readable {suffix[1:].upper()} image")
    if image.ndim == 3 and image.shape[2] in (3, 4):
        image = image[..., 2::-1]  # OpenCV gives BGR(A); make it RGB like the other readers
    return image


def _reject_tiff_stack(path: Path) -> None:
    """OpenCV would silently read only the first page of a multi-frame TIFF."""
    import tifffile  # tifffile: only for a TIFF

    try:
        with tifffile.TiffFile(path) as tif:
            series = tif.series[0]
            axes, shape = series.axes, series.shape
    except Exception:  # not parseable by tifffile: OpenCV gets its own chance
        return
    if any(a not in "YXS" and n > 1 for a, n in zip(axes, shape, strict=True)):
        raise InputError(f"{path}: TIFF holds a {len(shape)}-D stack {tuple(shape)}, "
                         f"expected a single 2-D frame")


def _read_tiff_fallback(path: Path) -> np.ndarray | None:
    import tifffile  # tifffile: only for a TIFF

    try:
        return np.asarray(tifffile.imread(path, key=0))
    except Exception:  # tifffile raises many types for a corrupt file; all mean "unreadable"
        return None


def _read_fits(path: Path) -> np.ndarray:
    from astropy.io import fits  # astropy: only for a FITS image

    if path.stat().st_size == 0:
        raise InputError(f"{path}: empty file (0 bytes)")
    size = path.stat().st_size
    try:
        with fits.open(path, memmap=False) as hdus:
            for index, hdu in enumerate(hdus):
                _check_declared_data(path, index, hdu, size)
                if not getattr(hdu, "is_image", False):
                    continue  # a table's data is never read
                if hdu.header.get("NAXIS", 0) >= 2:
                    _check_fits_size(path, hdu.header)
                if hdu.data is not None:
                    data = np.asarray(hdu.data)
                    if data.ndim == 2 or data.size == 0:
                        return data.copy()
                    if data.ndim > 2 and sum(s > 1 for s in data.shape) <= 2:
                        return data.reshape(data.shape[-2:]).copy()
                    raise InputError(f"{path}: FITS image is a {data.ndim}-D cube "
                                     f"{data.shape}, expected a 2-D frame")
    except InputError:
        raise
    except (OSError, ValueError, TypeError) as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise InputError(f"{path}: not a readable FITS file ({first})") from None
    raise InputError(f"{path}: FITS file has no image data")


def _check_declared_data(path: Path, index: int, hdu, file_size: int) -> None:
    """Refuse an HDU whose header declares more data than the file holds, before any of
    it is read (a 9 KB file may declare a 2e9-row table: gigabytes allocated)."""
    info = hdu.fileinfo()
    end = int(info["datLoc"]) + int(info["datSpan"])
    if end > file_size:
        raise InputError(f"{path}: FITS HDU {index} declares {int(info['datSpan']):,} bytes "
                         f"of data but the file ends {end - file_size:,} bytes short "
                         "(truncated or corrupt)")


def _check_fits_size(path: Path, header) -> None:
    """The pixel limit from NAXISn, before astropy reads the data."""
    axes = [int(header.get(f"NAXIS{i}", 1) or 1) for i in range(1, int(header["NAXIS"]) + 1)]
    pixels = math.prod(axes)
    check_pixels(axes[0], pixels // max(axes[0], 1), str(path))


def _as_grey_2d(image: np.ndarray, path: Path) -> np.ndarray:
    if image.size == 0:
        raise InputError(f"{path}: image has zero size {image.shape}")
    if image.dtype.kind not in "biuf":  # a complex image's imaginary part is not light
        raise InputError(f"{path}: pixel type {image.dtype} is not a real number "
                         "(complex or structured images are refused)")
    if image.ndim == 3 and image.shape[2] in (3, 4):
        rgb = image[..., :3].astype(np.float64)
        grey = rgb @ np.array([0.299, 0.587, 0.114])
        if np.issubdtype(image.dtype, np.integer):
            info = np.iinfo(image.dtype)
            grey = np.clip(np.rint(grey), info.min, info.max)
        image = grey.astype(image.dtype)
    elif image.ndim == 3 and image.shape[2] in (1, 2):
        image = image[..., 0]  # grey (+ alpha)
    if image.ndim != 2:
        raise InputError(f"{path}: image has shape {image.shape}, expected a 2-D grey frame")
    if image.dtype.byteorder not in ("=", "|"):
        image = image.astype(image.dtype.newbyteorder("="))
    if image.dtype == np.bool_:
        image = image.astype(np.uint8)
    return np.ascontiguousarray(image)


def _check_2d(path: Path, image: np.ndarray) -> np.ndarray:
    image = np.asarray(image)
    if image.ndim != 2 or image.size == 0:
        raise InputError(f"{path}: cannot write image of shape {image.shape}; need 2-D, "
                         f"non-empty")
    return image


def write_png16(path: str | Path, image: np.ndarray) -> None:
    """Write a 16-bit grey PNG atomically; floats are rounded and clipped to 0..65535."""
    import cv2  # cv2: OpenCV, loaded by the first image read

    path = Path(path)
    image = _check_2d(path, image)
    if image.dtype != np.uint16:
        image = np.clip(np.rint(np.nan_to_num(image.astype(np.float64))), 0, 65535)
        image = image.astype(np.uint16)
    ok, buf = cv2.imencode(".png", np.ascontiguousarray(image))
    if not ok:
        raise InputError(f"{path}: PNG encoding failed")
    with atomic_path(path) as tmp:
        buf.tofile(tmp)


def write_fits(path: str | Path, image: np.ndarray,
               header: Mapping[str, object] | None = None) -> None:
    """Write a 2-D array as the primary HDU of a FITS file, atomically.

    ``header`` is a mapping of keyword -> value (or an astropy Header).
    """
    from astropy.io import fits  # astropy: only for a FITS image

    path = Path(path)
    image = _check_2d(path, image)
    hdr = fits.Header()
    for key, value in (header or {}).items():
        if key.upper() not in _STRUCTURAL:  # astropy sets these from the data
            hdr[key] = value
    with atomic_path(path) as tmp:
        fits.PrimaryHDU(data=np.ascontiguousarray(image), header=hdr).writeto(
            tmp, overwrite=True)
