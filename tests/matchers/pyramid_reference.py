"""Pyramid's search as the numba kernels ran it before the compiled core
(startrack._core.matchers.pyramid): the same steps in plain Python, kept as the reference that
tests/matchers/test_core_search.py holds the compiled search to (the same hypotheses, in the same
order, and the same counters). Slow: for a few frames only."""

from __future__ import annotations

import math

import numpy as np
from startrack._core.shared import first_at_least


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


def group_window(pi, pj, s0, s1, hi_first, head, nxt, val):
    """Link the pairs of table entries [s0, s1), both ways round, into per-star lists:
    star x's partners are val[p] for p = head[x], nxt[p], ... until -1, in the order of a
    stable sort of the pairs by x (x as first star first, unless ``hi_first``). ``head``
    must be all -1; the caller resets it with :func:`ungroup_window`. Reads the window in
    sequence and writes only into the small per-frame arrays, which stay in cache."""
    w = s1 - s0
    for step in range(2):  # insert backwards: lists come out forwards
        half = step if hi_first else 1 - step
        for e in range(s1 - 1, s0 - 1, -1):
            x, y = (pi[e], pj[e]) if half == 0 else (pj[e], pi[e])
            p = (e - s0) + half * w
            nxt[p] = head[x]
            val[p] = y
            head[x] = p


def ungroup_window(pi, pj, s0, s1, head):
    for e in range(s0, s1):
        head[pi[e]] = -1
        head[pj[e]] = -1


def linked(head, nxt, val, x, y):
    p = head[x]
    while p >= 0:
        if val[p] == y:
            return True
        p = nxt[p]
    return False


def _triple(a, b, c):
    return (a[0] * (b[1] * c[2] - b[2] * c[1]) + a[1] * (b[2] * c[0] - b[0] * c[2])
            + a[2] * (b[0] * c[1] - b[1] * c[0]))


def _angle(a, b):
    d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    return math.acos(min(max(d, -1.0), 1.0))


def pair_angle(ang, vec, a, b):
    """``ang[a, b]``, the angle between observed stars a and b, computed on first use
    where the table holds NaN (as :func:`startrack.matchers._shared.geometry.angle_table`
    computes it): a frame solved on its first triple needs a few rows of the table."""
    value = ang[a, b]
    if np.isnan(value):
        dot = vec[a, 0] * vec[b, 0] + vec[a, 1] * vec[b, 1] + vec[a, 2] * vec[b, 2]
        value = math.acos(max(-1.0, min(1.0, dot)))
        ang[a, b] = value
        ang[b, a] = value
    return value


def _frame(a, b):
    """An orthonormal frame (columns) from two directions: a, a x b, a x (a x b)."""
    out = np.empty((3, 3))
    c = np.cross(a, b)
    c /= math.sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2])
    d = np.cross(a, c)
    for m in range(3):
        out[m, 0], out[m, 1], out[m, 2] = a[m], c[m], d[m]
    return out


def triad(cam_a, cam_b, sky_a, sky_b):
    """The rotation (camera to sky) taking cam_a to sky_a exactly and cam_b's direction
    about it onto sky_b's (TRIAD): good to the noise, enough to say where a star falls."""
    return _frame(sky_a, sky_b) @ _frame(cam_a, cam_b).T


def triangles(i, j, k, ang, vec, tol, cat, max_triangles, pi, pj, angle, heads):
    """Catalog triangles (I, J, K) whose three sides match the observed triple i < j < k,
    mirror images removed, in the order of the joins (I, J) by table entry, then K.
    Returns (rows, count); count > max_triangles means "too many" (the search stopped
    there). ``heads`` is (2, n_catalog) of -1, scratch, left as it was found."""
    lo, hi = np.empty(3), np.empty(3)
    for m, (a, b) in enumerate(((i, j), (j, k), (i, k))):
        side = pair_angle(ang, vec, a, b)
        lo[m], hi[m] = side - tol, side + tol
    s0 = np.searchsorted(angle, lo[0], side="left")
    s1 = np.searchsorted(angle, hi[0], side="right")
    t0 = np.searchsorted(angle, lo[1], side="left")
    t1 = np.searchsorted(angle, hi[1], side="right")
    u0 = np.searchsorted(angle, lo[2], side="left")
    u1 = np.searchsorted(angle, hi[2], side="right")
    out = np.empty((max_triangles + 1, 3), np.int64)
    if s1 <= s0 or t1 <= t0 or u1 <= u0:
        return out[:0], 0
    observed = _triple(vec[i], vec[j], vec[k])
    sides = math.sin(ang[j, k]) + math.sin(ang[i, k]) + math.sin(ang[i, j])  # filled above
    check = abs(observed) > tol * sides  # a nearly flat triangle keeps both handednesses
    nxt_jk, val_jk = np.empty(2 * (t1 - t0), np.int64), np.empty(2 * (t1 - t0), np.int64)
    nxt_ik, val_ik = np.empty(2 * (u1 - u0), np.int64), np.empty(2 * (u1 - u0), np.int64)
    group_window(pi, pj, t0, t1, False, heads[0], nxt_jk, val_jk)
    group_window(pi, pj, u0, u1, False, heads[1], nxt_ik, val_ik)
    count = 0
    for half in range(2):
        for e in range(s0, s1):
            big, small = (pi[e], pj[e]) if half == 0 else (pj[e], pi[e])
            p = heads[0][small]
            while p >= 0 and count <= max_triangles:
                kk = val_jk[p]
                p = nxt_jk[p]
                if kk == big or not linked(heads[1], nxt_ik, val_ik, big, kk):
                    continue
                if check and (_triple(cat[big], cat[small], cat[kk]) > 0) != (observed > 0):
                    continue
                out[count, 0], out[count, 1], out[count, 2] = big, small, kk
                count += 1
    ungroup_window(pi, pj, t0, t1, heads[0])
    ungroup_window(pi, pj, u0, u1, heads[1])
    return out[:min(count, max_triangles + 1)], count


def confirm(tri, ijk, ang, vec, tol, radius, cat, max_pyramids, lists):
    """The brightest fourth star r confirming 1 to ``max_pyramids`` pyramids (I, J, K, R):
    catalog stars R whose angles to I, J, K all lie within ``tol`` of the observed angles
    from r to i, j, k, and which lie within ``radius`` of where the triangle's attitude
    puts r (so that a flat triangle's mirror point does not count). Returns (r, rows) or
    (-1, no rows)."""
    n = len(vec)
    i, j, k = ijk[0], ijk[1], ijk[2]
    rows = np.empty((max_pyramids, 4), np.int64)
    buf = np.empty(4096, np.int64)
    rots = np.zeros((len(tri), 3, 3))
    have = np.zeros(len(tri), np.bool_)
    cos_radius = math.cos(radius)
    for r in range(n):
        if r in (i, j, k):
            continue
        count = 0
        for t in range(len(tri)):
            big, mid, last = tri[t, 0], tri[t, 1], tri[t, 2]
            side = pair_angle(ang, vec, i, r)
            lo, hi = side - tol, side + tol
            n_r = partners(big, lo, hi, i > r, *lists, buf)
            if n_r > len(buf):
                buf = np.empty(2 * n_r, np.int64)
                n_r = partners(big, lo, hi, i > r, *lists, buf)
            for q in range(n_r):
                star = buf[q]
                if star in (mid, last):
                    continue
                if abs(_angle(cat[mid], cat[star]) - pair_angle(ang, vec, j, r)) > tol:
                    continue
                if abs(_angle(cat[last], cat[star]) - pair_angle(ang, vec, k, r)) > tol:
                    continue
                if not have[t]:
                    rots[t] = triad(vec[i], vec[j], cat[big], cat[mid])
                    have[t] = True
                p = rots[t] @ vec[r]
                if p[0] * cat[star, 0] + p[1] * cat[star, 1] + p[2] * cat[star, 2] < cos_radius:
                    continue
                if count < max_pyramids:
                    rows[count, 0], rows[count, 1], rows[count, 2] = big, mid, last
                    rows[count, 3] = star
                count += 1
        if 1 <= count <= max_pyramids:
            return r, rows[:count]
    return -1, rows[:0]


def search(triples, start, ang, vec, tol, radius, cat, max_triangles, max_pyramids, tab,
           full, stats, heads):
    """Try ``triples`` from ``start`` until one gives hypotheses. Returns (next triple,
    observed stars (3 or 4), hypothesis rows); next = len(triples) when none did. ``stats``
    accumulates (triples tried, triangles found, candidate pairs, pivots). ``heads``:
    (2, n_catalog) scratch of -1, left as it was found (see :func:`triangles`)."""
    pi, pj, angle = tab[0], tab[1], tab[2]
    n = len(vec)
    for s in range(start, len(triples)):
        i, j, k = triples[s, 0], triples[s, 1], triples[s, 2]
        stats[0] += 1
        for a, b in ((i, j), (j, k), (i, k)):
            side = pair_angle(ang, vec, a, b)
            stats[2] += (np.searchsorted(angle, side + tol, side="right")
                         - np.searchsorted(angle, side - tol, side="left"))
        tri, count = triangles(i, j, k, ang, vec, tol, cat, max_triangles, pi, pj, angle,
                               heads)
        stats[1] += min(count, max_triangles)
        if count == 0 or count > max_triangles:
            continue
        if n == 3:
            if count <= max_pyramids:
                return s + 1, np.array([i, j, k]), tri
            continue
        stats[3] += 3 * (n - 3)
        r, rows = confirm(tri, triples[s], ang, vec, tol, radius, cat, max_pyramids, full)
        if r >= 0:
            return s + 1, np.array([i, j, k, r]), rows
    return len(triples), np.zeros(0, np.int64), np.zeros((0, 4), np.int64)
