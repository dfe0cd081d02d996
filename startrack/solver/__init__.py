"""Solving a frame: the pipeline (read, decide camera and sky, identify, correct), lost-in-
space identification, the field-of-view search and refit, hints, calibration and aberration.
"""

from startrack._lazy import lazy_exports

__all__ = [
    "Calibration", "Deadline", "FrameResult", "Hints", "Identifier", "Options", "Pipeline",
    "calibrate", "fit_camera", "identify",
]

__getattr__, __dir__ = lazy_exports(__name__, {
    "Calibration": "_calibrate",
    "Deadline": "_deadline",
    "FrameResult": "_identifier",
    "Hints": "_hints",
    "Identifier": "_identifier",
    "Options": "_options",
    "Pipeline": "_pipeline",
    "calibrate": "_calibrate",
    "fit_camera": "_fov_fit",
    "identify": "_lost_in_space",
})
