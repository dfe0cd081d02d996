"""Compiled medians of the centroider's sky model: exact, and faster than numpy's.

Tile medians (of ~50 block means each, four passes a frame) and the noise's median
absolute deviations (of ~25 000 samples) are taken here; the tile grid's clean-up is in
``startrack.extract_grid``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

_SAMPLED = 1024  # values; a longer array's first histogram spans a sample of it
_PIVOTED = 128  # values; a shorter array's median is narrowed by pivots (_pivot_middle)
_PIVOTS = 6  # at most; then the histograms go on
_FEW = 8  # values, so few that an insertion sort finishes


@njit(cache=True, nogil=True)
def _select(a, k):
    """Reorder ``a`` so that ``a[k]`` is its k-th smallest value (Hoare quickselect)."""
    lo, hi = 0, len(a) - 1
    while lo < hi:
        pivot = a[(lo + hi) // 2]
        i, j = lo, hi
        while i <= j:
            while a[i] < pivot:
                i += 1
            while a[j] > pivot:
                j -= 1
            if i <= j:
                a[i], a[j] = a[j], a[i]
                i += 1
                j -= 1
        if k <= j:
            hi = j
        elif k >= i:
            lo = i
        else:
            break
    return a[k]


@njit(cache=True, nogil=True)
def median(a, counts, sub):
    """Exact median of ``a`` (no NaN), equal to ``np.median``, several times faster.

    ``counts`` is the histogram's scratch, ``sub`` scratch of ``len(a)`` (see ``_middle``).
    """
    n = len(a)
    for i in range(n):  # a loop: numba's slice copy costs more than a short copy
        sub[i] = a[i]
    return middle(sub, n, counts)


@njit(cache=True, nogil=True)
def median_of(values):
    """``median`` of ``values`` (no NaN), with scratch of its own."""
    return median(values, np.empty(256, np.int64), np.empty(len(values)))


@njit(cache=True, nogil=True)
def middle(a, n, counts):
    """``median`` of ``a[:n]``, in place (``a`` is reordered)."""
    if n <= _PIVOTED:
        return _pivot_middle(a, n, counts)
    return _middle(a, n, (n - 1) // 2, n // 2, counts)


@njit(cache=True, nogil=True)
def _pivot_middle(a, n, counts):
    """``middle`` of a short array (a tile's block means): pivots narrow [low, high), the
    values among which the two middle ranks lie, until few are left, which are sorted.

    Each pivot is placed by linear interpolation of the ranks between the bounds, and
    costs one pass that counts the values below it (a compare and add that vectorises,
    unlike a histogram's scattered increments). Ties that no pivot splits, or a slow
    narrowing, end it early: ``_middle`` finishes on what is left.
    """
    k1, k2 = (n - 1) // 2, n // 2
    lo = hi = a[0]
    for i in range(n):
        lo = min(lo, a[i])
        hi = max(hi, a[i])
    if lo == hi:
        return lo
    low, high, top = lo, np.inf, hi  # top: no value below high is above it
    below, under = 0, n  # the counts of values below low and below high
    for _ in range(_PIVOTS):
        if under - below <= _FEW:
            break
        p = low + (top - low) * ((k1 + 1.0 - below) / (under - below))
        if not low < p < top:
            break
        c = 0
        for i in range(n):
            c += a[i] < p
        if c > k2:
            high, top, under = p, p, c
        elif c <= k1:
            low, below = p, c
        else:  # c = k2 = k1 + 1: the largest value below p and the smallest from p up
            v1, v2 = -np.inf, np.inf
            for i in range(n):
                v1 = max(v1, a[i] if a[i] < p else -np.inf)
                v2 = min(v2, a[i] if a[i] >= p else np.inf)
            return 0.5 * (v1 + v2)
    m = 0
    for i in range(n):  # those in [low, high), in place, no branch
        x = a[i]
        a[m] = x
        m += (x >= low) & (x < high)
    if m > _FEW:
        return _middle(a, m, k1 - below, k2 - below, counts)
    for i in range(1, m):  # an insertion sort
        x, j = a[i], i
        while j > 0 and a[j - 1] > x:
            a[j] = a[j - 1]
            j -= 1
        a[j] = x
    return a[k1 - below] if k1 == k2 else 0.5 * (a[k1 - below] + a[k2 - below])


@njit(cache=True, nogil=True)
def _middle(a, n, k1, k2, counts):
    """The mean of the k1-th and k2-th smallest of ``a[:n]`` (k2 = k1 or k1 + 1), which
    is reordered.

    A histogram finds the bin(s) holding the two ranks, and the values of those bins are
    kept (the bin of a value is monotone in it, so ranks are kept); again until few are
    left, which a quickselect finishes. The first histogram of a long array spans the
    central part of a sample of it (the values beyond go to the end bins), so that a few
    outliers do not crowd the rest into a few bins; later ones span [min, max].
    """
    first = n > _SAMPLED
    while True:
        lo, hi = _span(a, n, first)
        if lo == hi and not first:
            return lo
        if n <= 32:
            break
        nb = min(len(counts), max(16, n // 2))  # ~2 values a bin: cheap to clear and scan
        scale, top = nb / (hi - lo) if hi > lo else 0.0, nb - 1.0
        for b in range(nb):
            counts[b] = 0
        for i in range(n):
            counts[int(min(max((a[i] - lo) * scale, 0.0), top))] += 1
        cum, b1, b2, below = 0, -1, -1, 0
        for b in range(nb):
            nxt = cum + counts[b]
            if b1 < 0 and k1 < nxt:
                b1, below = b, cum
            if k2 < nxt:
                b2 = b
                break
            cum = nxt
        m = 0
        for i in range(n):  # bins b1 .. b2 (any between are empty), in place, no branch
            x = a[i]
            b = int(min(max((x - lo) * scale, 0.0), top))
            a[m] = x
            m += (b >= b1) & (b <= b2)
        if m == n and not first:
            break
        n, k1, k2, first = m, k1 - below, k2 - below, False
    v1 = _select(a[:n], k1)
    if k2 == k1:
        return v1
    v2 = np.inf  # the select leaves every value after rank k1 at or above it
    for x in a[k1 + 1:n]:
        v2 = min(v2, x)
    return 0.5 * (v1 + v2)


@njit(cache=True, nogil=True)
def _span(a, n, sampled):
    """[min, max] of ``a[:n]``; with ``sampled``, the 8th and 56th of 64 values spread
    over it instead (no full pass)."""
    if sampled:
        smp = np.sort(a[:n:n // 64][:64])
        return smp[8], smp[55]
    lo = hi = a[0]
    for i in range(n):  # min and max without branches: the loop vectorises
        lo = min(lo, a[i])
        hi = max(hi, a[i])
    return lo, hi


@njit(cache=True, nogil=True)
def mad_sigma(sample, to_sigma):
    """``to_sigma`` x the median absolute deviation of ``sample`` (not modified)."""
    counts = np.empty(4096, np.int64)
    sub = np.empty(len(sample))
    med = median(sample, counts, sub)
    for i in range(len(sample)):  # no temporaries
        sub[i] = abs(sample[i] - med)
    return to_sigma * middle(sub, len(sample), counts)
