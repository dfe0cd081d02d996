"""Reading one input: an image (its centroids extracted) or a centroid CSV, as a
:class:`FrameInput` for :mod:`startrack.pipeline`."""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from startrack.centroids import Centroids, read_centroid_csv
from startrack.errors import InputError, InputFileNotFoundError

CSV_SUFFIXES = (".csv",)


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
    from startrack.imageio import read_image

    image = read_image(path)
    read_ms = (time.perf_counter() - t0) * 1000.0
    return dataclasses.replace(image_input(image, str(path), centroid_config, path=path,
                                           downsample=downsample), read_ms=read_ms)


def image_input(image: np.ndarray, name: str, centroid_config=None,
                path: Path | None = None, downsample: int = 1) -> FrameInput:
    """A :class:`FrameInput` from a 2-D image array: its centroids extracted and timed.
    ``downsample`` N: found on the image binned N x N (summed), reported in the full
    image's pixels (docs/conventions.md: binned pixel i covers pixels N i to N i + N - 1,
    whose centre is N i + (N - 1) / 2)."""
    from startrack.extract import extract_centroids

    t0 = time.perf_counter()
    if downsample == 1:
        centroids = extract_centroids(image, centroid_config)
    else:
        binned = extract_centroids(bin_image(image, downsample), centroid_config)
        centroids = dataclasses.replace(binned, x=binned.x * downsample + (downsample - 1) / 2,
                                        y=binned.y * downsample + (downsample - 1) / 2)
    return FrameInput(name, centroids, image, (time.perf_counter() - t0) * 1000.0, path)


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
