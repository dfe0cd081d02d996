"""Input file to solution: sky, camera, database and matcher loaded once, many frames run.

``Identifier`` holds one loaded catalog, database and matcher and solves centroids or
files with them. ``Pipeline`` decides the camera and sky of each input (sidecar JSON
beside the input, overridden by options) and keeps one ``Identifier`` per distinct
(camera, sky), so a batch of frames from one camera loads everything once. Both
``startrack identify`` and ``startrack compare`` build on this.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from startrack.camera import Camera
from startrack.centroids import Centroids, read_centroid_csv
from startrack.database import StarDatabase
from startrack.errors import InputError
from startrack.identify import identify
from startrack.matchers import MatcherConfig, get_matcher
from startrack.output import Timing
from startrack.sidecar import read_sidecar, sidecar_path_for
from startrack.sky import Catalog, SkySpec, load_sky
from startrack.types import Observation, Solution
from startrack.verify import VerifyConfig

# The most reliable method measured (scripts/bench_identify.py, real-sky frames,
# scripts/false_positives.py): see the identify command's help text for the figures.
DEFAULT_METHOD = "pyramid"
# 1-sigma centroid error assumed when none is given: rendered and real frames centroid to
# a few tenths of a pixel; 0.5 px also leaves room for small lens distortion.
DEFAULT_SIGMA_PX = 0.5
# Magnitude-limit rule for Hipparcos: the faintest half-magnitude step at which an
# average frame holds at most this many catalog stars (20 deg -> 6.5, 11.4 deg -> 7.5).
TARGET_STARS_PER_FRAME = 80.0
# Catalog stars closer than this are one spot to the optics (and one centroid); merged,
# so that an identity is never a coin toss between two stars of a blend.
MIN_CENTROIDS = 3
CSV_SUFFIXES = (".csv",)


def default_mag_limit(camera: Camera, mags: np.ndarray, target: float = TARGET_STARS_PER_FRAME,
                      lo: float = 4.0, hi: float = 8.0) -> float:
    """Faintest limit in [lo, hi], in 0.5 mag steps, with <= ``target`` stars per frame."""
    frame_fraction = camera.width * camera.height / camera.f_px**2 / (4.0 * math.pi)
    mags = np.sort(np.asarray(mags, dtype=np.float64))
    best = lo
    for limit in np.arange(lo, hi + 0.25, 0.5):
        if np.searchsorted(mags, limit, side="right") * frame_fraction <= target:
            best = float(limit)
    return best


@dataclass(frozen=True)
class FrameResult:
    """One input's answer with what produced it."""

    input: str
    solution: Solution
    obs: Observation
    centroids: Centroids
    timing: Timing


def load_centroids(path: Path, centroid_config=None) -> tuple[Centroids, float,
                                                               tuple[int, int] | None]:
    """Centroids of an image (extracted) or a centroid CSV (read), the centroiding time in
    ms, and the image size (width, height) when the input is an image."""
    if path.suffix.lower() in CSV_SUFFIXES:
        return read_centroid_csv(path), 0.0, None
    from startrack.extract import extract_centroids
    from startrack.imageio import read_image

    image = read_image(path)
    t0 = time.perf_counter()
    centroids = extract_centroids(image, centroid_config)
    return centroids, (time.perf_counter() - t0) * 1000.0, (image.shape[1], image.shape[0])


class Identifier:
    """A loaded catalog, database and matcher for one camera and sky."""

    def __init__(self, camera: Camera, catalog: Catalog, method: str, *,
                 max_stars: int | None = None, sigma_px: float = DEFAULT_SIGMA_PX,
                 verify_config: VerifyConfig | None = None) -> None:
        if not (sigma_px > 0 and math.isfinite(sigma_px)):
            raise InputError(f"--sigma-px must be a positive number, got {sigma_px}")
        self.camera = camera
        self.catalog = catalog
        self.sigma_px = float(sigma_px)
        self.verify_config = verify_config or VerifyConfig()
        config = MatcherConfig() if max_stars is None else dataclasses.replace(
            MatcherConfig(), max_stars=int(max_stars))
        self.database = StarDatabase(catalog, camera)
        self.matcher = get_matcher(method)(self.database, config)
        t0 = time.perf_counter()
        self.matcher.prepare()
        self.load_seconds = time.perf_counter() - t0

    @classmethod
    def from_options(cls, camera: Camera, sky: SkySpec, method: str = DEFAULT_METHOD,
                     **kwargs) -> Identifier:
        return cls(camera, load_sky(sky, camera), method, **kwargs)

    def observation(self, centroids: Centroids) -> Observation:
        return Observation.from_pixels(centroids.x, centroids.y, self.camera, self.sigma_px)

    def solve(self, centroids: Centroids) -> tuple[Solution, Observation]:
        obs = self.observation(centroids)
        return identify(obs, self.matcher, self.verify_config), obs

    def run(self, path: str | Path, centroid_config=None) -> FrameResult:
        """Read ``path`` (image or centroid CSV) and identify its stars."""
        path = Path(path)
        t0 = time.perf_counter()
        centroids, centroid_ms, size = load_centroids(path, centroid_config)
        if size is not None and size != (self.camera.width, self.camera.height):
            raise InputError(f"{path}: image is {size[0]} x {size[1]} px but the camera is "
                             f"{self.camera.width} x {self.camera.height}")
        if len(centroids) < MIN_CENTROIDS:
            raise InputError(f"{path}: too few stars ({len(centroids)} found, "
                             f"need at least {MIN_CENTROIDS})")
        solution, obs = self.solve(centroids)
        total = (time.perf_counter() - t0) * 1000.0
        return FrameResult(str(path), solution, obs, centroids,
                           Timing(centroid_ms, solution.identify_ms, total))


@dataclass(frozen=True)
class Options:
    """What the user said; None means "from the sidecar, else the default"."""

    method: str = DEFAULT_METHOD
    camera: Camera | None = None
    fov_deg: float | None = None
    size: tuple[int, int] | None = None
    sky: str | None = None
    mag_limit: float | None = None
    epoch: float | None = None
    max_stars: int | None = None
    sigma_px: float = DEFAULT_SIGMA_PX


def _image_size(path: Path) -> tuple[int, int] | None:
    if path.suffix.lower() in CSV_SUFFIXES:
        return None
    from startrack.imageio import read_image

    image = read_image(path)
    return image.shape[1], image.shape[0]


class Pipeline:
    """Solve many inputs, each with its own camera and sky, sharing loaded databases."""

    def __init__(self, options: Options) -> None:
        self.options = options
        get_matcher(options.method)  # an unknown method fails before any work
        self._identifiers: dict[tuple[Camera, SkySpec], Identifier] = {}
        self._catalogs: dict[SkySpec, Catalog] = {}

    def setup_for(self, path: Path) -> tuple[Camera, SkySpec]:
        """The camera and sky for one input: options, else sidecar, else defaults."""
        opt = self.options
        side_camera, side_sky = None, None
        sidecar = sidecar_path_for(path)
        if sidecar.is_file() and sidecar != path:
            side_camera, side_sky, _ = read_sidecar(sidecar)
        camera = opt.camera or side_camera
        if camera is None and opt.fov_deg is not None:
            size = opt.size or _image_size(path)
            if size is None:
                raise InputError(f"{path}: a centroid CSV with --fov needs the image size "
                                 "(--size WxH) or use --camera FILE")
            camera = Camera.from_fov(size[0], size[1], opt.fov_deg)
        if camera is None:
            raise InputError(f"{path}: no camera (no sidecar {sidecar.name}); give --camera "
                             "FILE or --fov DEG")
        kind = opt.sky or (side_sky.kind if side_sky else "hipparcos")
        from_sidecar = side_sky is not None and side_sky.kind == kind
        sky = side_sky if from_sidecar else SkySpec(kind=kind)
        if opt.epoch is not None:
            sky = dataclasses.replace(sky, epoch=opt.epoch)
        if opt.mag_limit is not None:
            sky = dataclasses.replace(sky, mag_limit=opt.mag_limit)
        elif sky.kind == "hipparcos" and sky.mag_limit is None:
            from startrack.sky.hipparcos import hipparcos_arrays

            sky = dataclasses.replace(
                sky, mag_limit=default_mag_limit(camera, hipparcos_arrays()["mag"]))
        return camera, sky

    def identifier(self, camera: Camera, sky: SkySpec) -> Identifier:
        key = (camera, sky)
        if key not in self._identifiers:
            if sky not in self._catalogs:
                self._catalogs[sky] = load_sky(sky, camera)
            opt = self.options
            self._identifiers[key] = Identifier(camera, self._catalogs[sky], opt.method,
                                                max_stars=opt.max_stars, sigma_px=opt.sigma_px)
        return self._identifiers[key]

    def run(self, path: str | Path) -> tuple[FrameResult, Identifier]:
        path = Path(path)
        if not path.exists():
            raise InputError(f"{path}: no such file")
        identifier = self.identifier(*self.setup_for(path))
        return identifier.run(path), identifier
