"""Frame sequences: a frame solved near its predicted attitude (held to lost-in-space's proof),
the tracker's state, and sequences through the pipeline.
"""

from startrack._lazy import lazy_exports

__all__ = [
    "Prior", "prior_from_radec_roll", "SequenceSolver", "track", "TrackConfig", "Tracker",
]

__getattr__, __dir__ = lazy_exports(__name__, {
    "Prior": "_tracked_solve",
    "prior_from_radec_roll": "_sequence",
    "SequenceSolver": "_sequence",
    "track": "_tracked_solve",
    "TrackConfig": "_tracked_solve",
    "Tracker": "_lock_state",
})
