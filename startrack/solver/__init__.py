"""Solving a frame: the pipeline (read, decide camera and sky, identify, correct), lost-in-
space identification, the field-of-view search and refit, hints, calibration and aberration.
"""

from startrack._lazy import lazy_exports

__all__ = [
    "FrameSolver",
    "aberrate", "apparent_catalog", "calibrate", "Calibration", "cone_radius_deg",
    "cut_to_cone", "Deadline", "earth_velocity", "fit_camera", "format_parameters",
    "fov_range_deg", "frame_timing", "FrameInput", "FrameResult", "header_hints", "Hints",
    "Identifier", "identify", "image_input", "MARGIN", "observation", "Options", "parse_time",
    "Pipeline", "read_input", "refit_fov", "sky_record", "sky_text", "step_text",
    "user_hints",
]

__getattr__, __dir__ = lazy_exports(__name__, {
    "FrameSolver": "_protocol",
    "aberrate": "_aberration",
    "apparent_catalog": "_aberration",
    "calibrate": "_calibrate",
    "Calibration": "_calibrate",
    "cone_radius_deg": "_hints",
    "cut_to_cone": "_hints",
    "Deadline": "_deadline",
    "earth_velocity": "_aberration",
    "fit_camera": "_fov_fit",
    "format_parameters": "_calibrate_sigma",
    "fov_range_deg": "_hints",
    "frame_timing": "_identifier",
    "FrameInput": "_inputs",
    "FrameResult": "_identifier",
    "header_hints": "_hints",
    "Hints": "_hints",
    "Identifier": "_identifier",
    "identify": "_lost_in_space",
    "image_input": "_inputs",
    "MARGIN": "_fov_search",
    "observation": "_identifier",
    "Options": "_options",
    "parse_time": "_aberration",
    "Pipeline": "_pipeline",
    "read_input": "_inputs",
    "refit_fov": "_fov_refit",
    "sky_record": "_trail",
    "sky_text": "_trail",
    "step_text": "_trail",
    "user_hints": "_hints",
})
