"""What the user asked of a :class:`~startrack.solver._pipeline.Pipeline` (:class:`Options`), and
the camera that ``--fov`` makes of a sidecar's."""

from __future__ import annotations

from dataclasses import dataclass

from startrack.camera import Camera
from startrack.defaults import DEFAULT_FOV_TOLERANCE, DEFAULT_METHOD, DEFAULT_TIMEOUT_MS
from startrack.sky import SkySpec
from startrack.solver._hints import Hints


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
    #: 1-sigma centroid error (px); None: from each frame's star images
    #: (:func:`startrack.centroids.frame_sigma_px`)
    sigma_px: float | None = None
    #: how far the true FOV may be from the given one (a fraction); 0: exactly as given
    fov_tolerance: float = DEFAULT_FOV_TOLERANCE
    #: wall-clock limit per input, over all its stages (reason "timeout"); None: none
    timeout_ms: float | None = DEFAULT_TIMEOUT_MS
    #: observation time (astropy Time) for the aberration correction; None: a FITS
    #: input's DATE-OBS (plus half its EXPTIME), else no correction
    time: object | None = None
    #: the user's hints (startrack.solver._hints); a FITS header's complete them unless
    #: ``header_hints`` is False
    hints: Hints | None = None
    header_hints: bool = True
    #: centroids found on the image binned this many pixels square
    downsample: int = 1
    #: a config preset's sky (``--config``), taken before the sidecar's
    sky_spec: SkySpec | None = None


def with_fov(size: tuple[int, int], fov_deg: float, side_camera: Camera | None) -> Camera:
    """The camera of ``--fov``: it overrides the field of view only, so a sidecar camera of
    the same size keeps its principal point and lens (a principal point dropped to the
    centre moves the boresight, and the attitude with it)."""
    if side_camera is None or (side_camera.width, side_camera.height) != tuple(size):
        return Camera.from_fov(size[0], size[1], fov_deg)
    return Camera.from_fov(size[0], size[1], fov_deg, side_camera.cx, side_camera.cy,
                           side_camera.distortion)
