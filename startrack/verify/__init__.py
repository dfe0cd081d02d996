"""The one verification every answer passes: a hypothesis held to independent evidence, the
final labelling, the evidence gate and the solution's quality.
"""

from startrack._lazy import lazy_exports

__all__ = [
    "CAPTURE", "CONE_LOOKUP_MARGIN", "CONE_MARGIN", "cone_radius", "CONE_REUSE_FRACTION",
    "explains_bright_spots", "FrameVerifier", "label_params", "label_stars", "LabelConfig",
    "Labelling",
    "MAX_REFINEMENTS", "Quality", "refuse_without_evidence", "require_evidence", "rotation_of",
    "solution_quality", "Verification", "verify", "VerifyConfig", "wrapped_hypothesis",
]

__getattr__, __dir__ = lazy_exports(__name__, {
    "CAPTURE": "_frame",
    "CONE_LOOKUP_MARGIN": "_frame",
    "CONE_MARGIN": "_frame",
    "cone_radius": "_frame",
    "CONE_REUSE_FRACTION": "_frame",
    "explains_bright_spots": "_evidence",
    "FrameVerifier": "_frame",
    "label_params": "_labelling",
    "label_stars": "_labelling",
    "LabelConfig": "_labelling",
    "Labelling": "_labelling",
    "MAX_REFINEMENTS": "_frame",
    "Quality": "_quality",
    "refuse_without_evidence": "_evidence",
    "require_evidence": "_evidence",
    "rotation_of": "_verification",
    "solution_quality": "_quality",
    "Verification": "_verification",
    "verify": "_verification",
    "VerifyConfig": "_verification",
    "wrapped_hypothesis": "_verification",
})
