# The quad search's key lookup (included by quad.pyx): the table rows of the keys within
# the ratio tolerance of one image pattern, found through the level's bucket index and
# screened by the sorted-ratio first test.


cdef inline bint _bit(int p, int bit, const long long *lo, const long long *hi,
                      int j, long long *q) noexcept nogil:
    """Digit ``j`` of pick ``p``: ``hi[j]`` if the pick's ``bit`` is set, else ``lo[j]``;
    False when that repeats the other choice (lo == hi), so each key is visited once."""
    if (p >> bit) & 1:
        q[0] = hi[j]
        return hi[j] != lo[j]
    q[0] = lo[j]
    return True


cdef inline bint _passes(QuadTable t, QuadRules rules, Py_ssize_t row,
                         const double *r) noexcept nogil:
    """The first test: the table's stored ratios within the tolerance of ``r``."""
    cdef double d
    cdef int j
    cdef double worst = 0.0
    for j in range(5):
        d = fabs(t.ratios[row, j] * rules.ratio_unit - r[j])
        if d > worst:
            worst = d
    return worst <= rules.near


cdef inline Py_ssize_t _first_key(const int[::1] keys, Py_ssize_t lo, Py_ssize_t hi,
                                  long long key) noexcept nogil:
    """The first row of ascending ``keys[lo:hi]`` at least ``key`` (``hi`` if none)."""
    cdef Py_ssize_t mid
    while lo < hi:
        mid = (lo + hi) >> 1
        if keys[mid] < key:
            lo = mid + 1
        else:
            hi = mid
    return lo


cdef void _near_rows(QuadTable t, QuadRules rules, const double *r, const long long *lo,
                     const long long *hi, _Ints out):
    """Append to ``out``, ascending and once each, the table rows of the keys within the
    tolerance of ratios ``r`` (each digit ``lo`` or ``hi``) that pass the first test: the
    buckets of the three high digits in ascending order, each scanned from the least of
    the two low digits' keys (``low``, ascending; a bucket's keys are sorted: found by
    bisection) up to the greatest."""
    cdef long long n1 = rules.nbins, n2 = rules.nbins * rules.nbins
    cdef long long low[4]
    cdef long long base[8]
    cdef Py_ssize_t start[8]
    cdef Py_ssize_t end[8]
    cdef long long q0, q1, q2, q3, q4, key
    cdef Py_ssize_t row, b, nb = t.bucket.shape[0] - 1
    cdef int p, k, nlow = 0, nbk = 0
    for p in range(4):
        if _bit(p, 1, lo, hi, 1, &q1) and _bit(p, 0, lo, hi, 0, &q0):
            low[nlow] = q0 + n1 * q1
            nlow += 1
    for p in range(8):  # every bucket's span first: their reads overlap
        if not (_bit(p, 2, lo, hi, 4, &q4) and _bit(p, 1, lo, hi, 3, &q3)
                and _bit(p, 0, lo, hi, 2, &q2)):
            continue
        b = q2 + n1 * q3 + n2 * q4
        if b < nb:
            base[nbk], start[nbk], end[nbk] = b * n2, t.bucket[b], t.bucket[b + 1]
            nbk += 1
    for p in range(nbk):
        for row in range(_first_key(t.keys, start[p], end[p], base[p] + low[0]), end[p]):
            key = t.keys[row] - base[p]
            if key > low[nlow - 1]:
                break
            if key < low[0]:
                continue
            for k in range(nlow):
                if key == low[k]:
                    if _passes(t, rules, row, r):
                        out.push(row)
                    break


@cython.cdivision(True)  # largest > 0 and QuadRules' bin > 0
cdef void _key_ranges(QuadRules rules, const double *edges, double *r, long long *lo,
                      long long *hi) noexcept:
    """A pattern's sorted edge ratios (of its six ``edges``) and the key bins within the
    tolerance of each."""
    cdef double s[6]
    cdef double v, largest
    cdef int i, j
    for i in range(6):
        v = edges[i]
        j = i
        while j > 0 and s[j - 1] > v:
            s[j] = s[j - 1]
            j -= 1
        s[j] = v
    largest = s[5] if s[5] > 0 else 1.0
    for j in range(5):
        r[j] = s[j] / largest
        lo[j] = min(max(<long long>((r[j] - rules.tolerance) / rules.bin), 0), rules.nbins - 1)
        hi[j] = min(max(<long long>((r[j] + rules.tolerance) / rules.bin), 0), rules.nbins - 1)
