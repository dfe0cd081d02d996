"""The camera of docs/conventions.md: pixels <-> camera-frame unit vectors.

A pinhole with optional Brown-Conrady radial distortion (:mod:`startrack.camera._distortion`);
every pixel -> direction and direction -> pixel in startrack goes through this class, and
it through the compiled model (:class:`startrack._core.camera.optics.Optics`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from startrack._core.camera.optics import Optics
from startrack.camera._distortion import RadialDistortion
from startrack.errors import InputError


@dataclass(frozen=True)
class Camera:
    """Image size in pixels, focal length in pixels, principal point (cx, cy).

    Pixel (x, y) = (column, row), (0, 0) the centre of the top-left pixel. Camera +z is
    the boresight, +x towards increasing columns, +y towards increasing rows.
    Build one with :meth:`from_fov` or :meth:`from_optics` (they check their values), or
    read a camera file with :func:`startrack.camera.load_camera`.

    Parameters
    ----------
    width, height : int
        The image size in pixels.
    f_px : float
        The focal length in pixels.
    cx, cy : float
        The principal point in pixels (the image centre is ((width-1)/2, (height-1)/2)).
    distortion : RadialDistortion, optional
        Maps the ideal pinhole point to the observed pixel (None: a pinhole).

    Raises
    ------
    startrack.errors.InputError
        From :meth:`from_fov` and :meth:`from_optics`: a size, field of view or focal
        length out of range (a ``ValueError``).

    Examples
    --------
    >>> import numpy as np
    >>> from startrack.camera import Camera
    >>> camera = Camera.from_fov(1024, 768, 20.0)
    >>> round(camera.f_px, 3), camera.cx, camera.cy
    (2903.696, 511.5, 383.5)
    >>> camera.pixel_to_vector(np.array([511.5]), np.array([383.5]))  # the boresight
    array([[0., 0., 1.]])
    >>> x, y, in_front = camera.vector_to_pixel(np.array([[0.01, -0.02, 1.0]]))
    >>> round(float(x[0]), 2), round(float(y[0]), 2), bool(in_front[0])
    (540.54, 325.43, True)
    """

    width: int
    height: int
    f_px: float
    cx: float
    cy: float
    distortion: RadialDistortion | None = None

    @classmethod
    def from_fov(cls, width: int, height: int, fov_deg: float,
                 cx: float | None = None, cy: float | None = None,
                 distortion: RadialDistortion | None = None) -> Camera:
        """``fov_deg`` is the full horizontal angle across the image width."""
        if not 0 < fov_deg < 180:
            raise InputError(f"camera: fov_deg must be in (0, 180), got {fov_deg}")
        f = (width / 2.0) / math.tan(math.radians(fov_deg) / 2.0)
        return cls._checked(width, height, f, cx, cy, distortion)

    @classmethod
    def from_optics(cls, width: int, height: int, focal_length_mm: float, pixel_size_um: float,
                    cx: float | None = None, cy: float | None = None,
                    distortion: RadialDistortion | None = None) -> Camera:
        if focal_length_mm <= 0 or pixel_size_um <= 0:
            raise InputError("camera: focal_length_mm and pixel_size_um must be positive")
        return cls._checked(width, height, focal_length_mm * 1000.0 / pixel_size_um, cx, cy,
                            distortion)

    @classmethod
    def _checked(cls, width, height, f, cx, cy, distortion=None) -> Camera:
        if int(width) != width or int(height) != height or width < 1 or height < 1:
            raise InputError(f"camera: width and height must be positive integers, "
                             f"got {width} x {height}")
        cx = (width - 1) / 2.0 if cx is None else float(cx)
        cy = (height - 1) / 2.0 if cy is None else float(cy)
        camera = cls(int(width), int(height), float(f), cx, cy)
        return camera.with_distortion(distortion)

    def with_distortion(self, distortion: RadialDistortion | None) -> Camera:
        """This camera with another distortion (None or all-zero: a pinhole). The model
        must stay invertible over the whole image: a lens whose image folds back on
        itself inside the frame is an error."""
        if distortion is None or distortion.is_identity:
            return self._with(self.f_px, None)
        # in scalars, not arrays: a fitted lens is checked in every FOV refit; squares
        # as products, the arithmetic of the compiled fit's own check
        # (startrack._core.camera.fit), which refuses the same lenses
        ex = max(abs(-0.5 - self.cx), abs(self.width - 0.5 - self.cx))
        ey = max(abs(-0.5 - self.cy), abs(self.height - 0.5 - self.cy))
        rd2 = (ex * ex + ey * ey) / (self.f_px * self.f_px)
        r2 = distortion.max_r2
        scale = distortion.factor(r2) if math.isfinite(r2) else 0.0
        if math.isfinite(r2) and rd2 >= r2 * (scale * scale):
            raise InputError(f"camera: distortion {distortion.to_dict()} folds back inside "
                             "the image (not invertible at the corners)")
        return self._with(self.f_px, distortion)

    def with_focal(self, f_px: float) -> Camera:
        """This camera with the focal length ``f_px`` (px), the lens kept: what
        ``dataclasses.replace(camera, f_px=f_px)`` makes, for a fraction of its cost (a
        focal-length search makes cameras by the dozen per frame). Not checked: the
        caller's ``f_px`` is a fitted or searched one, positive and finite (a user's goes
        through :meth:`from_fov` or :meth:`from_optics`)."""
        return self._with(f_px, self.distortion)

    def _with(self, f_px: float, distortion: RadialDistortion | None) -> Camera:
        # the constructor itself: dataclasses.replace reads every field by name first
        return type(self)(self.width, self.height, f_px, self.cx, self.cy, distortion)

    @property
    def pinhole(self) -> Camera:
        """The same camera without distortion."""
        return self._with(self.f_px, None)

    @cached_property  # every input's record and stages name it
    def fov_deg(self) -> float:
        return math.degrees(2.0 * math.atan((self.width / 2.0) / self.f_px))

    @property
    def diagonal_fov_deg(self) -> float:
        """Largest angle between two pixels of the image (corner to corner)."""
        a = self.pixel_to_vector(np.array([0.0]), np.array([0.0]))[0]
        b = self.pixel_to_vector(np.array([self.width - 1.0]), np.array([self.height - 1.0]))[0]
        return math.degrees(math.acos(float(np.clip(a @ b, -1.0, 1.0))))

    @cached_property  # verification asks once per camera it builds a frame for
    def half_diagonal_deg(self) -> float:
        """Angle from the boresight to the farthest image corner."""
        if self.distortion is None:  # a pinhole: no array work
            return math.degrees(math.atan2(self.corner_radius_px, self.f_px))
        # the corners' arccos is numpy's, as ever; their cosines lie in [0, 1] (the z of a
        # unit vector 1 / |(u, v, 1)|): no clip. The largest angle, NaN winning (numpy's
        # max), turned to degrees (math's and numpy's are the same one product).
        angles = np.arccos(self.optics.corner_cosines())
        return math.degrees(float(np.maximum.reduce(angles)))

    @property
    def corner_radius_px(self) -> float:
        """Distance (px) from the principal point to the farthest image corner (the
        corner pixels' centres)."""
        left, right = 0.0 - self.cx, self.width - 1.0 - self.cx
        top, bottom = 0.0 - self.cy, self.height - 1.0 - self.cy
        return max(math.hypot(left, top), math.hypot(left, bottom), math.hypot(right, top),
                   math.hypot(right, bottom))

    @cached_property
    def optics(self) -> Optics:
        """The camera as the compiled core takes it (its one implementation of the
        pinhole and the lens), built once per camera."""
        lens = None if self.distortion is None else self.distortion.compiled
        return Optics(self.f_px, self.cx, self.cy, self.width, self.height, lens)

    def ideal_pixels(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Where observed pixels would be without distortion (the pinhole image)."""
        return self.optics.ideal_pixels(x, y)

    def pixel_to_vector(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Camera-frame unit vectors (N x 3) for pixel coordinates."""
        return self.optics.pixel_to_vector(x, y)

    def vector_to_pixel(self, v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pixel (x, y) of camera-frame vectors, and a mask of those in front (z > 0) and,
        with distortion, inside the radius where the lens model is invertible (beyond the
        fold a far-off star would land back inside the image)."""
        return self.optics.vector_to_pixel(v)

    def in_image(self, x: np.ndarray, y: np.ndarray, margin: float = 0.0) -> np.ndarray:
        """Mask of pixel positions inside the image, ``margin`` pixels from every edge."""
        return ((x >= -0.5 + margin) & (x <= self.width - 0.5 - margin)
                & (y >= -0.5 + margin) & (y <= self.height - 0.5 - margin))

    def to_dict(self) -> dict:
        """The camera-file keys of docs/conventions.md (``distortion`` only when there is one)."""
        out = {"width": self.width, "height": self.height, "fov_deg": self.fov_deg,
               "cx": self.cx, "cy": self.cy}
        if self.distortion is not None:
            out["distortion"] = self.distortion.to_dict()
        return out
