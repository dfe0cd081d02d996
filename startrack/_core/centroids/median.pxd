# Exact medians of the centroider's sky model (tile medians of ~50 block means, the MADs
# of ~25 000 noise samples): numpy's values, several times faster than a sort. A
# histogram (or, for short arrays, a few interpolated pivots) narrows the two middle ranks
# to a few values, which a selection finishes. No NaN may be given.

from libc.math cimport INFINITY, fabs

from startrack._core._stats cimport _select

cdef enum:
    SAMPLED = 1024  # values; a longer array's first histogram spans a sample of it
    PIVOTED = 128  # values; a shorter array's median is narrowed by pivots
    PIVOTS = 6  # at most; then the histograms go on
    FEW = 8  # values, so few that an insertion sort finishes


cdef struct Range:
    double lo
    double hi


cdef inline Range _span(double[::1] a, Py_ssize_t n, bint sampled) noexcept nogil:
    """[min, max] of ``a[:n]``; with ``sampled``, the 8th and 56th of 64 values spread
    over it instead (no full pass)."""
    cdef Range out
    cdef double smp[64]
    cdef double x
    cdef Py_ssize_t i, j, step
    if sampled:
        step = n // 64
        for i in range(64):  # an insertion sort of the sample
            x = a[i * step]
            j = i
            while j > 0 and smp[j - 1] > x:
                smp[j] = smp[j - 1]
                j -= 1
            smp[j] = x
        out.lo = smp[8]
        out.hi = smp[55]
        return out
    out.lo = a[0]
    out.hi = a[0]
    for i in range(n):
        out.lo = min(out.lo, a[i])
        out.hi = max(out.hi, a[i])
    return out


cdef inline double _ranks(double[::1] a, Py_ssize_t n, Py_ssize_t k1, Py_ssize_t k2,
                          long long[::1] counts) noexcept nogil:
    """The mean of the k1-th and k2-th smallest of ``a[:n]`` (k2 = k1 or k1 + 1), which is
    reordered. A histogram finds the bin(s) holding the two ranks and only their values
    are kept (a value's bin is monotone in it), until few are left for a selection. The
    first histogram of a long array spans the central part of a sample of it, so that a
    few outliers do not crowd the rest into a few bins; later ones span [min, max]."""
    cdef bint first = n > SAMPLED
    cdef Range span
    cdef Py_ssize_t nb, b, b1, b2, i, m, cum, nxt, below
    cdef double scale, top, x, v1, v2
    while True:
        span = _span(a, n, first)
        if span.lo == span.hi and not first:
            return span.lo
        if n <= 32:
            break
        nb = min(<Py_ssize_t>counts.shape[0], max(16, n // 2))  # ~2 values a bin
        scale = nb / (span.hi - span.lo) if span.hi > span.lo else 0.0
        top = nb - 1.0
        for b in range(nb):
            counts[b] = 0
        for i in range(n):
            counts[<Py_ssize_t>min(max((a[i] - span.lo) * scale, 0.0), top)] += 1
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
            b = <Py_ssize_t>min(max((x - span.lo) * scale, 0.0), top)
            a[m] = x
            m += (b >= b1) & (b <= b2)
        if m == n and not first:
            break
        n, k1, k2, first = m, k1 - below, k2 - below, False
    _select(a[:n], k1)
    v1 = a[k1]
    if k2 == k1:
        return v1
    v2 = INFINITY  # the selection leaves every value after rank k1 at or above it
    for i in range(k1 + 1, n):
        v2 = min(v2, a[i])
    return 0.5 * (v1 + v2)


cdef inline double _pivot_middle(double[::1] a, Py_ssize_t n,
                                 long long[::1] counts) noexcept nogil:
    """``middle`` of a short array (a tile's block means): pivots placed by linear
    interpolation of the ranks narrow [low, high), where the two middle ranks lie, each
    with a counting pass that vectorises; ties no pivot splits, or a slow narrowing, end
    it early and ``_ranks`` finishes."""
    cdef Py_ssize_t k1 = (n - 1) // 2, k2 = n // 2, i, j, m, c, below = 0, under = n
    cdef double lo = a[0], hi = a[0], low, high, top, p, x, v1, v2
    for i in range(n):
        lo = min(lo, a[i])
        hi = max(hi, a[i])
    if lo == hi:
        return lo
    low, high, top = lo, INFINITY, hi  # top: no value below high is above it
    for _ in range(PIVOTS):
        if under - below <= FEW:
            break
        p = low + (top - low) * ((k1 + 1.0 - below) / <double>(under - below))
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
            v1, v2 = -INFINITY, INFINITY
            for i in range(n):
                v1 = max(v1, a[i] if a[i] < p else -INFINITY)
                v2 = min(v2, a[i] if a[i] >= p else INFINITY)
            return 0.5 * (v1 + v2)
    m = 0
    for i in range(n):  # those in [low, high), in place, no branch
        x = a[i]
        a[m] = x
        m += (x >= low) & (x < high)
    if m > FEW:
        return _ranks(a, m, k1 - below, k2 - below, counts)
    for i in range(1, m):  # an insertion sort
        x, j = a[i], i
        while j > 0 and a[j - 1] > x:
            a[j] = a[j - 1]
            j -= 1
        a[j] = x
    if k1 == k2:
        return a[k1 - below]
    return 0.5 * (a[k1 - below] + a[k2 - below])


cdef inline double middle(double[::1] a, Py_ssize_t n, long long[::1] counts) noexcept nogil:
    """The median of ``a[:n]`` (np.median's value), in place (``a`` is reordered);
    ``counts``: the histogram's scratch, whose length bounds its bins."""
    if n <= PIVOTED:
        return _pivot_middle(a, n, counts)
    return _ranks(a, n, (n - 1) // 2, n // 2, counts)


cdef inline double median_copy(const double[::1] values, double[::1] scratch,
                               long long[::1] counts) noexcept nogil:
    """``middle`` of ``values`` (not modified), copied to ``scratch`` first."""
    cdef Py_ssize_t i, n = values.shape[0]
    for i in range(n):
        scratch[i] = values[i]
    return middle(scratch, n, counts)


cdef inline double mad(const double[::1] sample, double[::1] scratch,
                       long long[::1] counts) noexcept nogil:
    """The median absolute deviation of ``sample`` (not modified)."""
    cdef Py_ssize_t i, n = sample.shape[0]
    cdef double med = median_copy(sample, scratch, counts)
    for i in range(n):
        scratch[i] = fabs(sample[i] - med)
    return middle(scratch, n, counts)
