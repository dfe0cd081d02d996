"""The close pairs of a catalog: every pair of stars within an angle, sorted by angle, in
two sweeps and a bucket sort, split among threads for a table of millions."""

import numpy as np

from libc.math cimport acos, cos, sin

from startrack._core._stable cimport merge_sort

from startrack._core._threads import in_threads

cdef long long LOW_32 = 0xFFFFFFFF  # the low row of a packed pair

include "_buckets.pxi"


cdef void _sweep(const double[::1] x, const double[::1] y, const double[::1] z,
                 const long long[::1] order, Py_ssize_t first, Py_ssize_t stop, double band,
                 double cos_max, double scale, Py_ssize_t nb, long long[::1] slot,
                 long long[::1] rows, double[::1] angle, bint fill) noexcept nogil:
    """The z-band sweep over the close pairs whose first star (in z order) is one of
    ``first`` to ``stop - 1``. Each pair's bucket (of ``nb``) is its cosine's (pairs of
    a uniform sky spread evenly in cosine, and acos is monotone, so cosine buckets are
    angle buckets in reverse). Counting, it adds one to ``slot[bucket + 1]``; filling, it
    writes the pair (rows packed as i << 32 | j, i < j) at ``slot[bucket]`` and moves on."""
    cdef Py_ssize_t n = x.shape[0], a, b, k
    cdef double d
    cdef long long i, j
    for a in range(first, stop):
        for b in range(a + 1, n):
            if z[b] - z[a] > band:
                break
            d = x[a] * x[b] + y[a] * y[b] + z[a] * z[b]
            if d < cos_max:
                continue
            k = _bucket(1.0 - d, 0.0, scale, nb) if 1.0 - d > 0.0 else 0
            if not fill:
                slot[k + 1] += 1
                continue
            i, j = min(order[a], order[b]), max(order[a], order[b])
            rows[slot[k]] = (i << 32) | j
            angle[slot[k]] = acos(min(max(d, -1.0), 1.0))
            slot[k] += 1


cpdef double expected_pairs(Py_ssize_t n, double max_angle) noexcept:
    """How many pairs lie closer than ``max_angle`` among ``n`` stars spread evenly over
    the sky: of the n (n - 1) / 2 pairs, the share (1 - cos a) / 2 of the sphere that a
    cap of radius a covers. The one estimate behind the build's bucket count and its
    caller's thread count."""
    return n * (n - 1.0) / 4.0 * (1.0 - cos(max_angle))


def sorted_close_pairs(const double[:, ::1] vectors, double max_angle,
                       Py_ssize_t workers=1):
    """Every pair (i < j) of unit vectors closer than ``max_angle``: (i, j, angle), rows as
    int32, ascending in angle, equal angles in the order of the sweep (stars sorted by z,
    each compared only with those in the z band the angle allows).

    One sweep counts the pairs per bucket and a second writes each straight into its
    bucket of the final arrays, which are then sorted bucket by bucket: no array of
    millions is grown, sorted by index or gathered, as fresh pages cost more here than
    a second sweep. With ``workers`` > 1 each sweep and the sort are split among as many
    threads, the sweeps by first star: each worker's pairs go after those of the
    workers before it in every bucket, so the arrays are the same, bit for bit."""
    cdef Py_ssize_t n = vectors.shape[0], p, m, t
    order_arr = np.argsort(np.asarray(vectors)[:, 2], kind="stable")
    # The sweep reads the stars in z order: copied so, the inner loop runs along memory.
    xyz = np.asarray(vectors)[order_arr].T.copy()
    cdef const double[::1] x = xyz[0], y = xyz[1], z = xyz[2]
    cdef const long long[::1] order = order_arr
    cdef double band = 2.0 * sin(max_angle / 2.0)  # |dz| <= chord
    cdef double cos_max = cos(max_angle), span = 1.0 - cos(max_angle)
    cdef Py_ssize_t nb = max(<Py_ssize_t>(expected_pairs(n, max_angle) / PER_BUCKET), 1)
    cdef double scale = nb / span if span > 0.0 else 0.0
    workers = max(1, min(workers, n))
    firsts = [n * t // workers for t in range(workers + 1)]
    counts = [np.zeros(nb + 1, np.int64) for t in range(workers)]

    def count(Py_ssize_t t):
        cdef long long[::1] slot = counts[t], no_rows = np.empty(0, np.int64)
        cdef double[::1] no_angles = np.empty(0)
        cdef Py_ssize_t a0 = firsts[t], a1 = firsts[t + 1]
        with nogil:
            _sweep(x, y, z, order, a0, a1, band, cos_max, scale, nb, slot, no_rows,
                   no_angles, False)

    in_threads(count, workers)
    start_arr = np.cumsum(np.sum(counts, axis=0))  # counts[t][k + 1]: bucket k's
    m = start_arr[nb]
    rows_arr, angle_arr = np.empty(m, np.int64), np.empty(m)
    cdef long long[::1] rows = rows_arr
    cdef double[::1] angle = angle_arr
    # worker t writes each bucket's pairs after those of the workers before it
    fills = [start_arr[:nb].copy()]
    for t in range(1, workers):
        fills.append(fills[t - 1] + counts[t - 1][1:])

    def fill(Py_ssize_t t):
        cdef long long[::1] slot = fills[t]
        cdef Py_ssize_t a0 = firsts[t], a1 = firsts[t + 1]
        with nogil:
            _sweep(x, y, z, order, a0, a1, band, cos_max, scale, nb, slot, rows, angle, True)

    in_threads(fill, workers)
    # the sort's buckets split where each worker gets about as many pairs
    edges = [0, *np.searchsorted(start_arr, [m * t // workers for t in range(1, workers)]),
             nb]
    failed = []

    def sort(Py_ssize_t t):
        cdef const long long[::1] start = start_arr
        cdef Py_ssize_t b0 = edges[t], b1 = max(edges[t], edges[t + 1])
        cdef int status
        with nogil:
            status = _sort_bucket_range(start, rows, angle, b0, b1)
        if status < 0:
            failed.append(t)

    in_threads(sort, workers)
    if failed:
        raise MemoryError("sorted_close_pairs: no memory for a bucket's merge")
    i_arr, j_arr = np.empty(m, np.int32), np.empty(m, np.int32)
    cdef int[::1] pi = i_arr, pj = j_arr
    with nogil:
        for p in range(m):
            pi[p], pj[p] = <int>(rows[p] >> 32), <int>(rows[p] & LOW_32)
    return i_arr, j_arr, angle_arr
