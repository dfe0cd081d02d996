"""Reading one input: an image (its centroids extracted) or a centroid CSV, as a
:class:`FrameInput` for :mod:`startrack.pipeline`."""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from startrack.centroids import Centroids, read_centroid_csv
from startrack.errors import InputError

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


def read_input(path: str | Path, centroid_config=None) -> FrameInput:
    """Read an image (and extract its centroids) or a centroid CSV."""
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: no such file")
    t0 = time.perf_counter()
    if path.suffix.lower() in CSV_SUFFIXES:
        centroids = read_centroid_csv(path)
        return FrameInput(str(path), centroids, path=path,
                          read_ms=(time.perf_counter() - t0) * 1000.0)
    from startrack.imageio import read_image

    image = read_image(path)
    read_ms = (time.perf_counter() - t0) * 1000.0
    return dataclasses.replace(image_input(image, str(path), centroid_config, path=path),
                               read_ms=read_ms)


def image_input(image: np.ndarray, name: str, centroid_config=None,
                path: Path | None = None) -> FrameInput:
    """A :class:`FrameInput` from a 2-D image array: its centroids extracted and timed."""
    from startrack.extract import extract_centroids

    t0 = time.perf_counter()
    centroids = extract_centroids(image, centroid_config)
    return FrameInput(name, centroids, image, (time.perf_counter() - t0) * 1000.0, path)
