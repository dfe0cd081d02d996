"""Image dimensions read from a file's header, before any pixel is decoded.

Decoding a 20000 x 20000 frame takes gigabytes, so :func:`check_image_size` refuses an
image above :func:`max_image_pixels` (``$STARTRACK_MAX_IMAGE_PIXELS``, default
:data:`DEFAULT_MAX_IMAGE_PIXELS` = 8192 x 8192) from its header alone. ``simulate``
applies the same limit to the camera it renders.
"""

from __future__ import annotations

import datetime as dt
import os
import struct
from pathlib import Path

from startrack.errors import InputError
from startrack.input_checks import IMAGE_PIXELS, env_number

DEFAULT_MAX_IMAGE_PIXELS = 8192 * 8192
_JPEG_SOF = {0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF}


def max_image_pixels() -> int:
    """The largest image (width x height) startrack reads or renders."""
    return int(env_number("STARTRACK_MAX_IMAGE_PIXELS", DEFAULT_MAX_IMAGE_PIXELS, IMAGE_PIXELS))


def check_pixels(width: int, height: int, where: str) -> None:
    """InputError when ``width x height`` is above the documented limit."""
    limit = max_image_pixels()
    if width * height > limit:
        raise InputError(f"{where}: {width} x {height} = {width * height:,} pixels, above "
                         f"the limit of {limit:,} (STARTRACK_MAX_IMAGE_PIXELS)")


def _png(head: bytes) -> tuple[int, int] | None:
    if head[:8] == b"\x89PNG\r\n\x1a\n" and head[12:16] == b"IHDR":
        return struct.unpack(">II", head[16:24])
    return None


def _bmp(head: bytes) -> tuple[int, int] | None:
    if head[:2] == b"BM" and len(head) >= 26:
        w, h = struct.unpack("<ii", head[18:26])
        return abs(w), abs(h)
    return None


def _pnm(head: bytes) -> tuple[int, int] | None:
    if len(head) < 2 or head[:1] != b"P" or head[1:2] not in b"123456":
        return None
    tokens = []
    for line in head[2:].split(b"\n"):
        tokens += line.split(b"#", 1)[0].split()
        if len(tokens) >= 2:
            break
    try:
        return int(tokens[0]), int(tokens[1])
    except (IndexError, ValueError):
        return None


def _jpeg(path: Path) -> tuple[int, int] | None:
    with open(path, "rb") as fh:
        if fh.read(2) != b"\xff\xd8":
            return None
        while True:
            marker = fh.read(2)
            if len(marker) < 2 or marker[0] != 0xFF:
                return None
            length = fh.read(2)
            if len(length) < 2:
                return None
            if marker[1] in _JPEG_SOF:
                sof = fh.read(5)
                return (struct.unpack(">HH", sof[1:5])[::-1]) if len(sof) == 5 else None
            fh.seek(struct.unpack(">H", length)[0] - 2, os.SEEK_CUR)


def _tiff(path: Path) -> tuple[int, int] | None:
    import tifffile  # tifffile: only a TIFF's header needs it

    try:
        with tifffile.TiffFile(path) as tif:
            page = tif.pages[0]
            return int(page.imagewidth), int(page.imagelength)
    except Exception:  # unparseable here: the decoder reports it
        return None


def header_size(path: Path) -> tuple[int, int] | None:
    """(width, height) from the header of a PNG, TIFF, JPEG, BMP or PNM file; None when
    the header says nothing (the decoder then has its own say)."""
    suffix = path.suffix.lower()
    if suffix in (".tif", ".tiff"):
        return _tiff(path)
    if suffix in (".jpg", ".jpeg"):
        return _jpeg(path)
    with open(path, "rb") as fh:
        head = fh.read(512)
    return _png(head) or _bmp(head) or _pnm(head)


def check_image_size(path: Path) -> None:
    """Refuse, from its header, an image too large to decode (see the module docstring)."""
    size = header_size(path)
    if size is not None:
        check_pixels(size[0], size[1], str(path))


def date_obs_of(path: str | Path | None) -> str | None:
    """The exposure time recorded in an image file, ISO 8601, or None when not known:
    DATE-OBS of a FITS file, the DateTime tag of a TIFF."""
    if path is None:
        return None
    path = Path(path)
    suffix = path.suffix.lower()
    try:
        if suffix in (".fits", ".fit", ".fts"):
            from astropy.io import fits  # astropy: the header reader loads it only here

            value = fits.getheader(path).get("DATE-OBS")
            return str(value) if value else None
        if suffix in (".tif", ".tiff"):
            import tifffile  # tifffile: only a TIFF's header needs it

            with tifffile.TiffFile(path) as tif:
                tag = tif.pages[0].tags.get("DateTime")
            if tag is None:
                return None
            return dt.datetime.strptime(str(tag.value), "%Y:%m:%d %H:%M:%S").isoformat()
    except (OSError, ValueError, KeyError):
        return None
    return None
