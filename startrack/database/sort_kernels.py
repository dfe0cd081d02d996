"""The bisection of a sorted range, as a numba kernel, for the numba kernels that still
import it (startrack.database.cone, startrack.matching.kernels and
nearest_fallback_kernels). The compiled core's one is ``first_at_least`` in
``startrack/_core/_sort.pxd``; this module goes when its last importer is compiled."""

from __future__ import annotations

from numba import njit


@njit(cache=True, inline="always")
def first_at_least(values, lo, hi, x):
    """The first position in ascending ``values[lo:hi]`` whose value is >= ``x`` (``hi``
    if none)."""
    while lo < hi:
        mid = (lo + hi) >> 1
        if values[mid] < x:
            lo = mid + 1
        else:
            hi = mid
    return lo
