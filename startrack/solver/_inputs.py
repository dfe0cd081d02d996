"""Reading one input: an image (its centroids extracted) or a centroid CSV, as a
:class:`FrameInput` for :mod:`startrack.solver._pipeline`."""

from __future__ import annotations

import contextlib
import dataclasses
import importlib
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from startrack.centroids import Centroids, extract_centroids, read_centroid_csv
from startrack.errors import InputError, InputFileNotFoundError
from startrack.io import FITS_SUFFIXES, read_image

CSV_SUFFIXES = (".csv",)
#: the side of the crop the extraction is warmed on (big enough for its threaded path)
WARM_CROP_PX = 512
_warmed: set[tuple[str, str]] = set()  # (pixel type, config) extracted in this process


@dataclass(frozen=True)
class FrameInput:
    """One input, read once: its centroids, the image they came from (None for a centroid
    list) and the centroiding time in ms."""

    name: str
    centroids: Centroids
    image: np.ndarray | None = None
    centroid_ms: float = 0.0
    path: Path | None = None
    read_ms: float = 0.0  # reading the file, before centroiding
    #: one-time cost paid here (the extraction warmed): ``timing_ms.setup``, not centroid
    setup_ms: float = 0.0

    @property
    def size(self) -> tuple[int, int] | None:
        """(width, height) of the image, None for a centroid list."""
        return None if self.image is None else (self.image.shape[1], self.image.shape[0])


def read_input(path: str | Path, centroid_config=None, downsample: int = 1) -> FrameInput:
    """Read an image (and extract its centroids, on the image binned ``downsample``
    pixels square) or a centroid CSV."""
    path = Path(path)
    if not path.exists():
        raise InputFileNotFoundError(f"{path}: no such file")
    if path.is_dir():  # the API's path (the command line's click refuses it first)
        raise InputError(f"{path}: is a directory, not an image or centroid CSV")
    t0 = time.perf_counter()
    if path.suffix.lower() in CSV_SUFFIXES:
        centroids = read_centroid_csv(path)
        return FrameInput(str(path), centroids, path=path,
                          read_ms=(time.perf_counter() - t0) * 1000.0)
    reader_ms = _reader_loaded(path)
    t0 = time.perf_counter()
    image = read_image(path)
    read_ms = (time.perf_counter() - t0) * 1000.0
    frame = image_input(image, str(path), centroid_config, path=path, downsample=downsample)
    return dataclasses.replace(frame, read_ms=read_ms, setup_ms=frame.setup_ms + reader_ms)


def _reader_loaded(path: Path) -> float:
    """Import the image reader's library (astropy's FITS module, else OpenCV) before the
    read is timed; the milliseconds of a first import (``timing_ms.setup``), else 0."""
    module = "astropy.io.fits" if path.suffix.lower() in FITS_SUFFIXES else "cv2"
    if module in sys.modules:
        return 0.0
    t0 = time.perf_counter()
    with contextlib.suppress(ImportError):  # read_image says what is missing
        importlib.import_module(module)  # a heavy optional library: on first use only
    return (time.perf_counter() - t0) * 1000.0


def image_input(image: np.ndarray, name: str, centroid_config=None,
                path: Path | None = None, downsample: int = 1) -> FrameInput:
    """A :class:`FrameInput` from a 2-D image array: its centroids extracted and timed.
    ``downsample`` N: found on the image binned N x N (summed), reported in the full
    image's pixels (docs/conventions.md: binned pixel i covers pixels N i to N i + N - 1,
    whose centre is N i + (N - 1) / 2)."""
    t0 = time.perf_counter()
    source = image if downsample == 1 else bin_image(image, downsample)
    setup_ms = warm_extraction(source, centroid_config)
    centroids = extract_centroids(source, centroid_config)
    if downsample != 1:
        centroids = dataclasses.replace(centroids,
                                        x=centroids.x * downsample + (downsample - 1) / 2,
                                        y=centroids.y * downsample + (downsample - 1) / 2)
    centroid_ms = (time.perf_counter() - t0) * 1000.0 - setup_ms
    return FrameInput(name, centroids, image, centroid_ms, path, setup_ms=setup_ms)


def warm_extraction(image: np.ndarray, centroid_config=None) -> float:
    """Extract the centroids of a crop of ``image`` (:data:`WARM_CROP_PX` square around
    its brightest pixel) once per process, pixel type and configuration, so the timed
    extraction after it compiles or loads no kernel; returns the milliseconds it took
    (0 when already warm)."""
    key = (np.asarray(image).dtype.str, repr(centroid_config))
    if key in _warmed:
        return 0.0
    t0 = time.perf_counter()
    iy, ix = np.unravel_index(int(np.argmax(image)), image.shape)
    y0, x0 = (max(0, min(int(i) - WARM_CROP_PX // 2, n - WARM_CROP_PX))
              for i, n in zip((iy, ix), image.shape, strict=True))
    extract_centroids(np.ascontiguousarray(image[y0:y0 + WARM_CROP_PX, x0:x0 + WARM_CROP_PX]),
                      centroid_config)
    _warmed.add(key)
    return (time.perf_counter() - t0) * 1000.0


def bin_image(image: np.ndarray, n: int) -> np.ndarray:
    """``image`` summed over n x n blocks (float32; a partial block at the right or
    bottom edge is dropped)."""
    if not (isinstance(n, int | np.integer) and n >= 1):
        raise InputError(f"downsample must be an integer >= 1, got {n!r}")
    h, w = (image.shape[0] // n) * n, (image.shape[1] // n) * n
    if h == 0 or w == 0:
        raise InputError(f"downsample {n} leaves nothing of a {image.shape[1]} x "
                         f"{image.shape[0]} image")
    block = np.asarray(image[:h, :w], dtype=np.float32).reshape(h // n, n, w // n, n)
    return block.sum(axis=(1, 3))
