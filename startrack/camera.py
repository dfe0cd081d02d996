"""The pinhole camera of shared/interfaces.md: pixels <-> camera-frame unit vectors."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from startrack.errors import InputError


@dataclass(frozen=True)
class Camera:
    """Image size in pixels, focal length in pixels, principal point (cx, cy).

    Pixel (x, y) = (column, row), (0, 0) the centre of the top-left pixel. Camera +z is
    the boresight, +x towards increasing columns, +y towards increasing rows.
    """

    width: int
    height: int
    f_px: float
    cx: float
    cy: float

    @classmethod
    def from_fov(cls, width: int, height: int, fov_deg: float,
                 cx: float | None = None, cy: float | None = None) -> Camera:
        """``fov_deg`` is the full horizontal angle across the image width."""
        if not 0 < fov_deg < 180:
            raise InputError(f"camera: fov_deg must be in (0, 180), got {fov_deg}")
        f = (width / 2.0) / math.tan(math.radians(fov_deg) / 2.0)
        return cls._checked(width, height, f, cx, cy)

    @classmethod
    def from_optics(cls, width: int, height: int, focal_length_mm: float, pixel_size_um: float,
                    cx: float | None = None, cy: float | None = None) -> Camera:
        if focal_length_mm <= 0 or pixel_size_um <= 0:
            raise InputError("camera: focal_length_mm and pixel_size_um must be positive")
        return cls._checked(width, height, focal_length_mm * 1000.0 / pixel_size_um, cx, cy)

    @classmethod
    def _checked(cls, width, height, f, cx, cy) -> Camera:
        if int(width) != width or int(height) != height or width < 1 or height < 1:
            raise InputError(f"camera: width and height must be positive integers, "
                             f"got {width} x {height}")
        cx = (width - 1) / 2.0 if cx is None else float(cx)
        cy = (height - 1) / 2.0 if cy is None else float(cy)
        return cls(int(width), int(height), float(f), cx, cy)

    @property
    def fov_deg(self) -> float:
        return math.degrees(2.0 * math.atan((self.width / 2.0) / self.f_px))

    @property
    def diagonal_fov_deg(self) -> float:
        """Largest angle between two pixels of the image (corner to corner)."""
        a = self.pixel_to_vector(np.array([0.0]), np.array([0.0]))[0]
        b = self.pixel_to_vector(np.array([self.width - 1.0]), np.array([self.height - 1.0]))[0]
        return math.degrees(math.acos(float(np.clip(a @ b, -1.0, 1.0))))

    @property
    def half_diagonal_deg(self) -> float:
        """Angle from the boresight to the farthest image corner."""
        corners_x = np.array([0.0, self.width - 1.0, 0.0, self.width - 1.0])
        corners_y = np.array([0.0, 0.0, self.height - 1.0, self.height - 1.0])
        v = self.pixel_to_vector(corners_x, corners_y)
        return float(np.degrees(np.arccos(np.clip(v[:, 2], -1, 1))).max())

    def pixel_to_vector(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Camera-frame unit vectors (N x 3) for pixel coordinates."""
        x = np.asarray(x, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        v = np.stack([(x - self.cx) / self.f_px, (y - self.cy) / self.f_px, np.ones_like(x)],
                     axis=-1)
        return v / np.linalg.norm(v, axis=-1, keepdims=True)

    def vector_to_pixel(self, v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pixel (x, y) of camera-frame vectors, and a mask of those in front (z > 0)."""
        v = np.asarray(v, dtype=np.float64)
        z = v[..., 2]
        front = z > 1e-12
        zs = np.where(front, z, 1.0)
        x = self.cx + self.f_px * v[..., 0] / zs
        y = self.cy + self.f_px * v[..., 1] / zs
        return x, y, front

    def in_image(self, x: np.ndarray, y: np.ndarray, margin: float = 0.0) -> np.ndarray:
        """Mask of pixel positions inside the image, ``margin`` pixels from every edge."""
        return ((x >= -0.5 + margin) & (x <= self.width - 0.5 - margin)
                & (y >= -0.5 + margin) & (y <= self.height - 0.5 - margin))

    def to_dict(self) -> dict:
        return {"width": self.width, "height": self.height, "fov_deg": self.fov_deg,
                "cx": self.cx, "cy": self.cy}
