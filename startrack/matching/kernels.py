"""The hybrid search's partner lookup on a pair table's neighbour lists, in numba until
that search is compiled with the core (the Pyramid and angle searches use
:func:`startrack._core.pairs.partners`, the same walk).

The "lists" are :attr:`startrack.matching.pairs.PairIndex.lists`: (start_lo, nbr_lo,
ang_lo, start_hi, nbr_hi, ang_hi), each star's partners as first and as second star of a
pair, in table order (so by angle).
"""

from __future__ import annotations

from numba import njit

from startrack.database.sort_kernels import first_at_least


@njit(cache=True)
def partners(star, lo, hi, hi_first, start_lo, nbr_lo, ang_lo, start_hi, nbr_hi, ang_hi,
             out):
    """Write the partners of ``star`` whose pair angle lies in [lo, hi] into ``out``; return
    how many. The ``lo`` run comes first unless ``hi_first``: the order of a stable sort
    of the pairs seen one way round or the other. Writes at most len(out)."""
    count = 0
    for run in range(2):
        if (run == 0) == hi_first:
            nbr, ang, a, b = nbr_hi, ang_hi, start_hi[star], start_hi[star + 1]
        else:
            nbr, ang, a, b = nbr_lo, ang_lo, start_lo[star], start_lo[star + 1]
        p = first_at_least(ang, a, b, lo)
        while p < b and ang[p] <= hi:
            if count < len(out):
                out[count] = nbr[p]
            count += 1
            p += 1
    return count
