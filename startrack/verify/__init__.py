"""The one verification every answer passes: a hypothesis held to independent evidence, the
final labelling, the evidence gate and the solution's quality.
"""

from startrack._lazy import lazy_exports

__all__ = [
    "Labelling", "Quality", "Verification", "VerifyConfig", "label_stars",
    "refuse_without_evidence", "solution_quality", "verify",
]

__getattr__, __dir__ = lazy_exports(__name__, {
    "Labelling": "_labelling",
    "Quality": "_quality",
    "Verification": "_verification",
    "VerifyConfig": "_verification",
    "label_stars": "_labelling",
    "refuse_without_evidence": "_evidence",
    "solution_quality": "_quality",
    "verify": "_verification",
})
