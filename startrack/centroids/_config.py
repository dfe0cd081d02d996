"""The settings of centroid extraction (:func:`startrack.centroids.extract_centroids`)."""

from __future__ import annotations

from dataclasses import dataclass

_AREA_PER_MPX = 400  # default max_area of a 1024 x 1024 frame, scaled with the frame


@dataclass(frozen=True)
class CentroidConfig:
    """Settings of ``extract_centroids``; the defaults suit 8- and 16-bit star frames.

    k_sigma: detection threshold, in noise sigmas of the smoothed background-free image.
    background_size: px, side of the tiles whose medians model the sky background; larger
        than a star, smaller than the scale of vignetting or sky glow.
    min_area, max_area: px, accepted size of a detected spot (detection-mask pixels).
        ``max_area=None`` scales with the frame: 400 px per 1024 x 1024 pixels (at least
        400), since the same optics on a larger detector spread a star over more pixels.
    max_saturated_area: px, size limit of a spot with a saturated pixel, whose image
        blooms with brightness (None = 4 x max_area): the brightest stars are kept.
    hot_pixel_fraction: a spot whose brightest pixel holds more than this fraction of the
        flux in the 3x3 box around it, or whose 8 neighbours hold no significant flux, is a
        hot pixel (or cosmic ray), not a star, whose image always spreads over neighbours.
    saturation: pixel value at which a spot is flagged saturated; None = the integer
        dtype's maximum (no flag for float images).
    smooth: pre-smooth with a 3x3 Gaussian for detection only (centroids use raw pixels).
    max_stars: keep at most this many, brightest first (None = all).
    fast: one sky model, without the second, source-masked estimate: somewhat faster, at
        the cost of the faintest stars near bright ones (bright stars' wings leak into
        the sky model); ``FAST`` is this preset.
    threads: threads that the passes over the pixels run on (None = the cores this
        process may use, or fewer when other processes keep them busy). The result is
        the same, bit for bit, whatever the number.
    shape_cut: drop the spots far more elongated than the frame's typical star image
        (``startrack.centroids._extract.unlike_stars``): a caption's letters, a
        satellite's trail, a cosmic ray's track, a nebula's filaments.
    """

    k_sigma: float = 5.0
    background_size: int = 31
    min_area: int = 2
    max_area: int | None = None
    max_saturated_area: int | None = None
    hot_pixel_fraction: float = 0.9
    saturation: float | None = None
    smooth: bool = True
    max_stars: int | None = None
    fast: bool = False
    threads: int | None = None
    shape_cut: bool = True

    def __post_init__(self) -> None:
        if not self.k_sigma > 0:
            raise ValueError(f"k_sigma must be > 0, got {self.k_sigma}")
        if self.background_size < 3:
            raise ValueError(f"background_size must be >= 3 px, got {self.background_size}")
        if not 1 <= self.min_area <= (self.max_area or self.min_area):
            raise ValueError(f"need 1 <= min_area <= max_area, got {self.min_area}, "
                             f"{self.max_area}")
        if self.max_saturated_area is not None and self.max_saturated_area < self.min_area:
            raise ValueError(f"max_saturated_area must be >= min_area, got "
                             f"{self.max_saturated_area}")
        if not 0 < self.hot_pixel_fraction <= 1:
            raise ValueError(f"hot_pixel_fraction must be in (0, 1], got "
                             f"{self.hot_pixel_fraction}")
        if self.threads is not None and self.threads < 1:
            raise ValueError(f"threads must be >= 1, got {self.threads}")

    def area_limits(self, shape: tuple[int, int]) -> tuple[int, int]:
        """(max_area, max_saturated_area) in px for a frame of ``shape``."""
        auto = max(_AREA_PER_MPX, round(_AREA_PER_MPX * shape[0] * shape[1] / 2**20))
        max_area = self.max_area if self.max_area is not None else auto
        saturated = self.max_saturated_area if self.max_saturated_area is not None \
            else 4 * max_area
        return max_area, saturated


FAST = CentroidConfig(fast=True)
