"""Frame sequences: a frame solved near its predicted attitude (held to lost-in-space's proof),
the tracker's state, and sequences through the pipeline.
"""

from startrack._lazy import lazy_exports

__all__ = [
    "Prior", "SequenceSolver", "TrackConfig", "Tracker", "track",
]

__getattr__, __dir__ = lazy_exports(__name__, {
    "Prior": "_track",
    "SequenceSolver": "_sequence",
    "TrackConfig": "_track",
    "Tracker": "_tracker",
    "track": "_track",
})
