"""Compiled (numba) sorting of the database builds: a stable bucket argsort, the gathers
that apply it, and the k-vector's merge, each one pass over millions of entries; and the
bisection of a sorted range that the lookups share."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

PER_BUCKET = 8  # values per bucket on average
CROWDED = 32  # more in one bucket: merge sort, as insertion sort is quadratic


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


@njit(cache=True)
def stable_argsort(values, lo, hi):
    """The stable ascending argsort of ``values`` (all in [lo, hi]) by a bucket sort:
    counting sort into about one bucket per ``PER_BUCKET`` values, then insertion sort
    inside each (a stable merge sort for crowded ones), O(n) for spread-out values
    where a comparison sort of millions takes seconds.

    The keys travel with the indices, so each bucket is sorted in contiguous memory;
    fewer buckets than values keep the counts in cache while the values are scattered.
    """
    n = len(values)
    nb = max(n // PER_BUCKET, 1)
    scale = nb / (hi - lo) if hi > lo else 0.0
    start = np.zeros(nb + 1, np.int64)
    for e in range(n):
        start[min(int((values[e] - lo) * scale), nb - 1) + 1] += 1
    for b in range(nb):
        start[b + 1] += start[b]
    fill = start[:-1].copy()
    order = np.empty(n, np.int64)
    key = np.empty(n, values.dtype)
    for e in range(n):  # the same bucket arithmetic as above, so the counts match
        b = min(int((values[e] - lo) * scale), nb - 1)
        order[fill[b]] = e
        key[fill[b]] = values[e]
        fill[b] += 1
    for b in range(nb):  # insertion sort; strict comparison keeps equal values in order
        if start[b + 1] - start[b] > CROWDED:
            _merge_sort(order, key, start[b], start[b + 1])
            continue
        for p in range(start[b] + 1, start[b + 1]):
            e, x = order[p], key[p]
            q = p - 1
            while q >= start[b] and key[q] > x:
                order[q + 1], key[q + 1] = order[q], key[q]
                q -= 1
            order[q + 1], key[q + 1] = e, x
    return order


@njit(cache=True)
def _merge_sort(order, key, a, b):
    """Stable bottom-up merge sort of key[a:b], order[a:b] alongside (numba's own
    np.argsort(kind="mergesort") would do, but takes seconds to compile)."""
    tmp_o = np.empty(b - a, np.int64)
    tmp_k = np.empty(b - a, key.dtype)
    width = 1
    while width < b - a:
        for lo in range(a, b, 2 * width):
            mid, hi = min(lo + width, b), min(lo + 2 * width, b)
            i, j = lo, mid
            for t in range(lo - a, hi - a):
                if j >= hi or (i < mid and key[i] <= key[j]):  # ties: left first
                    tmp_o[t] = order[i]
                    tmp_k[t] = key[i]
                    i += 1
                else:
                    tmp_o[t] = order[j]
                    tmp_k[t] = key[j]
                    j += 1
        for t in range(b - a):
            order[a + t] = tmp_o[t]
            key[a + t] = tmp_k[t]
        width *= 2


@njit(cache=True)
def take_pairs(order, i, j, angle):
    """(i, j, angle)[order], the rows as int32: the pair table's arrays in angle order."""
    n = len(order)
    ti, tj, ta = np.empty(n, np.int32), np.empty(n, np.int32), np.empty(n, angle.dtype)
    for p in range(n):
        e = order[p]
        ti[p], tj[p], ta[p] = i[e], j[e], angle[e]
    return ti, tj, ta


@njit(cache=True)
def take_triangles(order, rows, area, polar):
    """(rows, area, polar)[order], the rows as int32: the triangle table in area order."""
    n = len(order)
    tr = np.empty((n, 3), np.int32)
    ta, tp = np.empty(n, area.dtype), np.empty(n, polar.dtype)
    for p in range(n):
        e = order[p]
        tr[p, 0], tr[p, 1], tr[p, 2] = rows[e, 0], rows[e, 1], rows[e, 2]
        ta[p], tp[p] = area[e], polar[e]
    return tr, ta, tp


@njit(cache=True)
def is_sorted(values):
    """Whether ``values`` ascend (NaNs compare as np.diff(values) < 0 does: never)."""
    ascending = True
    for e in range(1, len(values)):
        if values[e] < values[e - 1]:
            ascending = False
            break
    return ascending


@njit(cache=True)
def count_at_most(values, m, q):
    """``np.searchsorted(values, m * np.arange(len(values)) + q, side="right")`` for
    ascending ``values`` and m > 0: one merge, where the binary searches cost
    O(n log n) cache misses, and no array of the n line points."""
    n = len(values)
    k = np.empty(n, np.int64)
    p = 0
    for e in range(n):
        z = m * e + q  # e is exact as a float (n < 2**53): the same z as numpy's
        while p < n and values[p] <= z:
            p += 1
        k[e] = p
    return k


@njit(cache=True)
def kvector_range(values, kk, m, q, lo, hi):
    """Positions [start, stop) of the sorted ``values`` within [lo, hi], from the k-vector
    ``kk`` on the line m*i + q (:class:`startrack.database.kvector.KVector`): two entries
    of ``kk``, then the slice trimmed at its ends (at most about one bin's worth of values
    on each side). An empty or NaN range is (0, 0)."""
    n = len(values)
    if n == 0 or not hi >= lo:
        return 0, 0
    jb = int(min(max(math.floor((lo - q) / m), 0.0), n - 1.0))
    jt = int(min(max(math.ceil((hi - q) / m), 0.0), n - 1.0))
    # kk[jb] values lie at or below z(jb) <= lo, so the answer starts at or after it;
    # kk[jt] values lie at or below z(jt) >= hi, so it ends at or before it.
    start, stop = kk[jb], kk[jt]
    while start > 0 and values[start - 1] >= lo:
        start -= 1
    while start < n and values[start] < lo:  # not bounded by stop: it may still be short
        start += 1
    while stop < n and values[stop] <= hi:
        stop += 1
    while stop > start and values[stop - 1] > hi:
        stop -= 1
    return start, stop
