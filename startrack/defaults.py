"""Defaults and limits the command line shows or checks before any work, in a module that
imports nothing heavy: ``startrack --help`` and ``--version`` must not load the compiled
kernels, scipy.spatial or astropy (docs/conventions.md). The modules that use these
values import them from here."""

from __future__ import annotations

from startrack.input_checks import PAIRS, env_number

# The most reliable method measured (scripts/bench/bench_identify.py, the real-sky frames and
# scripts/validation/false_positives.py; docs/results.md has the figures).
DEFAULT_METHOD = "pyramid"
#: the matchers startrack ships (startrack.matchers registers them; a test holds the two
#: equal); plugins add theirs
BUILTIN_METHODS = ("angle", "angle_closed", "angle_open", "astrometry", "hybrid",
                   "hybrid_nofourth", "hybrid_single", "pyramid", "quad", "radial",
                   "radial_noise", "radial_paper", "radial_paper_patch", "radial_patch",
                   "sss", "sss_paper", "sss_paper_patch", "sss_patch", "tetra3", "tetra3rs",
                   "triangle", "triangle_first", "triangle_nopivot")
#: default ``--fov-tolerance``: the true FOV may be this fraction above or below nominal
DEFAULT_FOV_TOLERANCE = 0.10
#: the horizontal FOVs (degrees) searched when none is given: down to 0.8 deg, where the
#: Tycho-2 sky still puts about 20 stars in an average 4:3 frame
BLIND_FOV_RANGE = (0.8, 40.0)
#: Below this horizontal FOV the default sky is Gaia: Hipparcos (complete to about
#: V = 8) leaves fewer than about 50 stars in an average frame.
GAIA_BELOW_FOV_DEG = 8.0
#: default ``--timeout-ms``: every input's search stops here, not solved with reason
#: "timeout" (docs/limits.md); a frame a star tracker can solve takes well under a second
DEFAULT_TIMEOUT_MS = 60_000.0
#: default ``--prior-sigma-deg``
DEFAULT_PRIOR_SIGMA_DEG = 1.0
#: ``--scale-units`` of a scale hint
SCALE_UNITS = ("degwidth", "arcsecperpix", "focalmm")

# Memory bounds (documented in docs/conventions.md). Every catalog pair closer than the
# image diagonal is tabled; building the table peaks near 60 bytes per pair (measured:
# 408 million pairs took 23 GB), so DEFAULT_MAX_PAIRS is about 1.5 GB.
DEFAULT_MAX_PAIRS = 25_000_000


def max_pairs() -> int:
    """The pair budget: ``$STARTRACK_MAX_PAIRS``, else :data:`DEFAULT_MAX_PAIRS`."""
    return int(env_number("STARTRACK_MAX_PAIRS", DEFAULT_MAX_PAIRS, PAIRS))

__all__ = [
    "BLIND_FOV_RANGE", "BUILTIN_METHODS", "DEFAULT_FOV_TOLERANCE", "DEFAULT_MAX_PAIRS",
    "DEFAULT_METHOD", "DEFAULT_PRIOR_SIGMA_DEG", "DEFAULT_TIMEOUT_MS", "GAIA_BELOW_FOV_DEG",
    "SCALE_UNITS",
    "max_pairs",
]
