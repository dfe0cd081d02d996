"""The camera: pixels <-> unit vectors (pinhole and Brown-Conrady
radial distortion), and camera files.
"""

from startrack._lazy import lazy_exports

__all__ = [
    "Camera", "RadialDistortion", "camera_from_dict", "load_camera",
]

__getattr__, __dir__ = lazy_exports(__name__, {
    "Camera": "_model",
    "RadialDistortion": "_distortion",
    "camera_from_dict": "_file",
    "load_camera": "_file",
})
