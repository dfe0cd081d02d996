"""The camera: pixels <-> unit vectors (pinhole and Brown-Conrady
radial distortion), and camera files.
"""

from startrack._lazy import lazy_exports

__all__ = [
    "StarVectors", "stars_in_view",
    "Camera", "RadialDistortion", "camera_from_dict", "load_camera",
]

__getattr__, __dir__ = lazy_exports(__name__, {
    "StarVectors": "_projection",
    "stars_in_view": "_projection",
    "Camera": "_model",
    "RadialDistortion": "_distortion",
    "camera_from_dict": "_file",
    "load_camera": "_file",
})
