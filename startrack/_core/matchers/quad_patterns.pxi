# Pattern geometry of the quad search (included by quad.pyx): the image's own patterns, by
# the rule of startrack.database._quads.all_quads on the few brightest stars of one frame, by
# brute force (no k-d tree for 16 stars), and the edge angles of image and catalog patterns;
# numpy's own arcsin and cos, so that every radius, bound and edge agrees with the table
# builder's to the last bit.


cdef object _edges(QuadRules rules, const double[:, ::1] vec, const long long[:, ::1] quads):
    """The six edge angles (M x 6, radians) of each pattern (rows of ``vec``), with
    numpy's arcsin: the table builder (:func:`startrack._core.database.quad_table.
    pattern_keys`) uses C's asin, which agrees with it to the last bit here
    (tests/database/test_database_kernels.py); where a SIMD arcsin differed by an ulp, the
    lookup's tolerance covers it."""
    out = np.empty((quads.shape[0], 6))
    cdef double[:, ::1] half = out
    cdef Py_ssize_t p, a, b
    cdef int k
    cdef double d0, d1, d2
    for p in range(quads.shape[0]):
        for k in range(6):
            a, b = quads[p, rules.edges[k, 0]], quads[p, rules.edges[k, 1]]
            d0, d1, d2 = vec[a, 0] - vec[b, 0], vec[a, 1] - vec[b, 1], vec[a, 2] - vec[b, 2]
            half[p, k] = min(max(sqrt(d0 * d0 + d1 * d1 + d2 * d2) / 2.0, 0.0), 1.0)
    np.arcsin(out, out=out)
    out *= 2.0
    return out


cdef void _nearest_rows(const double[:, ::1] v, Py_ssize_t n, Py_ssize_t kk, double bound2,
                        double *kth, long long[:, ::1] near) noexcept:
    """Each row's distance to its ``kk``-th nearest other row (inf beyond the chord bound,
    whose square is ``bound2``) and those ``kk`` rows (``n`` beyond the bound), nearest
    first."""
    cdef double d2[64]
    cdef int order[64]
    cdef Py_ssize_t a, b, i, j, kept
    cdef double dx, dy, dz
    for a in range(n):
        kept = 0  # the kk + 1 nearest so far, by a stable insertion (ties by row)
        for b in range(n):
            dx, dy, dz = v[a, 0] - v[b, 0], v[a, 1] - v[b, 1], v[a, 2] - v[b, 2]
            d2[b] = dx * dx + dy * dy + dz * dz
            if kept == kk + 1 and not d2[order[kk]] > d2[b]:
                continue
            j = kept if kept <= kk else kk
            kept = min(kept + 1, kk + 1)
            while j > 0 and d2[order[j - 1]] > d2[b]:
                order[j] = order[j - 1]
                j -= 1
            order[j] = <int>b
        kth[a] = sqrt(d2[order[kk]]) if d2[order[kk]] < bound2 else INFINITY
        for i in range(kk):
            near[a, i] = order[i + 1] if d2[order[i + 1]] < bound2 else n


cdef void _pattern_radii(const double[:, ::1] v, Py_ssize_t n, Py_ssize_t kk, double min_rad,
                         double max_rad, long long[:, ::1] near, double *radii):
    """Each row's pattern radius, as ``quads.pattern_radii`` (numpy's arcsin); ``near``
    keeps a row's nearest rows only where its radius exceeds ``min_rad``."""
    angle = np.empty(n)
    cdef double[::1] a = angle
    cdef double kth[64]
    cdef Py_ssize_t i, j
    _nearest_rows(v, n, kk, (2.0 * sin(min(max_rad, M_PI) / 2.0)) ** 2, kth, near)
    for i in range(n):
        a[i] = min(max(kth[i] / 2.0, 0.0), 1.0)
    np.arcsin(angle, out=angle)
    for i in range(n):
        radii[i] = min(max(2.0 * a[i] if isfinite(kth[i]) else max_rad, min_rad), max_rad)
        if not radii[i] > min_rad:
            for j in range(kk):
                near[i, j] = n


cdef bint _linked(const double[:, ::1] v, Py_ssize_t n, Py_ssize_t kk, double min_chord2,
                  const long long[:, ::1] near, unsigned char[:, ::1] link) noexcept:
    """``link[a, b]`` (a < b): b is within the pattern radius of a (the pairs within
    ``min_rad``, and a sparse row's nearest rows); whether any pair is linked."""
    cdef Py_ssize_t a, b
    cdef double dx, dy, dz
    cdef bint any_link = False
    for a in range(n):
        for b in range(a + 1, n):
            dx, dy, dz = v[a, 0] - v[b, 0], v[a, 1] - v[b, 1], v[a, 2] - v[b, 2]
            link[a, b] = (dx * dx + dy * dy + dz * dz) <= min_chord2
            any_link |= link[a, b]
        for b in range(kk):
            if a < near[a, b] < n:
                link[a, near[a, b]] = 1
                any_link = True
    return any_link


cdef inline double _dot(const double[:, ::1] v, Py_ssize_t a, Py_ssize_t b) noexcept nogil:
    return v[a, 0] * v[b, 0] + v[a, 1] * v[b, 1] + v[a, 2] * v[b, 2]


cdef class _ImageStars:
    """The image's pattern stars (its first ``n`` rows, brightest first) as the patterns
    are made of them: which star each one reaches (``link[a, b]``, a < b), how many of
    those it takes (``cap``), the cosine of its largest edge (``cos_max``) and every
    pair's edge angle (``angle[a * n + b]``, both ways), so a pattern's edges are six
    reads."""
    cdef Py_ssize_t n
    cdef const double[:, ::1] v
    cdef const unsigned char[:, ::1] link
    cdef double cos_max[64]
    cdef long long cap[64]
    cdef double[::1] angle


cdef _ImageStars _image_stars(QuadRules rules, const double[:, ::1] vectors, double max_edge,
                              double sparse_edge):
    """The pattern stars of ``quads.all_quads``'s rule on the first ``image_stars`` rows
    with ``image_nearest`` nearest rows; None when they make no pattern."""
    cdef Py_ssize_t n = min(vectors.shape[0], rules.image_stars)
    cdef Py_ssize_t kk = min(rules.image_nearest, n - 1), i
    cdef double radii[64]
    if n < 4:
        return None
    near_rows = np.full((n, max(kk, 0)), n, np.int64)
    cdef long long[:, ::1] near = near_rows
    if kk <= 0 or sparse_edge <= max_edge:
        kk = 0
        for i in range(n):
            radii[i] = max_edge
    else:
        _pattern_radii(vectors, n, kk, max_edge, sparse_edge, near, radii)
    link = np.zeros((n, n), np.uint8)
    cdef unsigned char[:, ::1] linked = link
    if not _linked(vectors, n, kk, (2.0 * sin(min(max_edge, M_PI) / 2.0)) ** 2, near, linked):
        return None
    stars = _ImageStars()
    stars.n, stars.v, stars.link = n, vectors, link
    cos_max = np.empty(n)
    cdef double[::1] c = cos_max
    for i in range(n):  # a sparse row's patterns reach further, to its nearest rows
        c[i] = min(2.0 * radii[i], max(sparse_edge, max_edge)) if radii[i] > max_edge else radii[i]
        stars.cap[i] = (max(rules.image_nearest, rules.image_stars) if radii[i] > max_edge
                        else rules.image_stars)
    np.cos(cos_max, out=cos_max)
    for i in range(n):
        stars.cos_max[i] = c[i]
    stars.angle = _pair_angles(vectors, n)
    return stars


cdef object _pair_angles(const double[:, ::1] vec, Py_ssize_t n):
    """The edge angle (radians) of every pair of the first ``n`` rows (n x n, flat), as
    :func:`_edges` computes a pattern's (the chord of the lower row minus the higher,
    numpy's arcsin)."""
    out = np.zeros(n * n)
    cdef double[::1] half = out
    cdef Py_ssize_t a, b
    cdef double d0, d1, d2
    for a in range(n):
        for b in range(a + 1, n):
            d0, d1, d2 = vec[a, 0] - vec[b, 0], vec[a, 1] - vec[b, 1], vec[a, 2] - vec[b, 2]
            half[a * n + b] = min(max(sqrt(d0 * d0 + d1 * d1 + d2 * d2) / 2.0, 0.0), 1.0)
    np.arcsin(out, out=out)
    for a in range(n):
        for b in range(a + 1, n):
            half[a * n + b] *= 2.0
            half[b * n + a] = half[a * n + b]
    return out


cdef inline void _quad_edges(QuadRules rules, _ImageStars stars, const long long *q,
                             double *e) noexcept:
    """The six edge angles of the image pattern of stars ``q``."""
    cdef int k
    for k in range(6):
        e[k] = stars.angle[q[rules.edges[k, 0]] * stars.n + q[rules.edges[k, 1]]]


cdef inline Py_ssize_t _reach(_ImageStars stars, Py_ssize_t a, long long *rows) noexcept:
    """The rows star ``a``'s patterns take (its first ``cap[a]`` linked higher rows)."""
    cdef Py_ssize_t b, m = 0
    for b in range(a + 1, stars.n):
        if stars.link[a, b] and m < stars.cap[a]:
            rows[m] = b
            m += 1
    return m


cdef void _enumerate(_ImageStars stars, _Ints out):
    """Every pattern (a, b, c, d), a < b < c < d, with b, c, d among the first ``cap[a]``
    linked rows of a and every edge within the angle whose cosine is ``cos_max[a]``: by a,
    then b, c, d."""
    cdef long long rows[64]
    cdef Py_ssize_t a, i, j, k, m
    cdef double cm
    for a in range(stars.n):
        m = _reach(stars, a, rows)
        cm = stars.cos_max[a]
        for i in range(m):
            for j in range(i + 1, m):
                if _dot(stars.v, rows[i], rows[j]) < cm:
                    continue
                for k in range(j + 1, m):
                    if _dot(stars.v, rows[i], rows[k]) < cm or _dot(stars.v, rows[j], rows[k]) < cm:
                        continue
                    out.push(a)
                    out.push(rows[i])
                    out.push(rows[j])
                    out.push(rows[k])


cdef void _enumerate_ending(_ImageStars stars, Py_ssize_t d, _Ints out):
    """The patterns of :func:`_enumerate` whose faintest star is ``d``, in its order."""
    cdef long long rows[64]
    cdef Py_ssize_t a, i, j, k, m
    cdef double cm
    for a in range(d - 2):
        m = _reach(stars, a, rows)
        k = 0
        while k < m and rows[k] < d:
            k += 1
        if k == m or rows[k] != d:
            continue
        cm = stars.cos_max[a]
        for i in range(k):
            for j in range(i + 1, k):
                if (_dot(stars.v, rows[i], rows[j]) < cm or _dot(stars.v, rows[i], d) < cm
                        or _dot(stars.v, rows[j], d) < cm):
                    continue
                out.push(a)
                out.push(rows[i])
                out.push(rows[j])
                out.push(d)


cdef object _as_quads(_Ints out):
    return np.asarray(out.a[:out.n]).reshape(-1, 4).copy()


cdef object _quads_edges(QuadRules rules, _ImageStars stars, const long long[:, ::1] quads):
    """The six edge angles (M x 6) of each image pattern."""
    edges = np.empty((quads.shape[0], 6))
    cdef double[:, ::1] e = edges
    cdef Py_ssize_t p
    for p in range(quads.shape[0]):
        _quad_edges(rules, stars, &quads[p, 0], &e[p, 0])
    return edges


def image_quads(QuadRules rules, const double[:, ::1] vectors, double max_edge,
                double sparse_edge):
    """The image's patterns and their six edge angles (radians), as the search makes them:
    ``quads.all_quads`` of the first ``image_stars`` rows of ``vectors`` (brightest first)
    with pattern edges up to ``max_edge``, or ``sparse_edge`` where the stars are sparse."""
    stars = _image_stars(rules, vectors, max_edge, sparse_edge)
    if stars is None:
        return np.zeros((0, 4), np.int64), np.empty((0, 6))
    cdef _Ints out = _Ints()
    _enumerate(stars, out)
    quads = _as_quads(out)
    return quads, _quads_edges(rules, stars, quads)


def image_quads_by_faintest(QuadRules rules, const double[:, ::1] vectors, double max_edge,
                            double sparse_edge):
    """:func:`image_quads`' patterns in the order :func:`first_confirmed` looks them up
    (by their faintest star, as made one faintest star at a time), with their edges."""
    stars = _image_stars(rules, vectors, max_edge, sparse_edge)
    if stars is None:
        return np.zeros((0, 4), np.int64), np.empty((0, 6))
    cdef _Ints out = _Ints()
    cdef Py_ssize_t d
    for d in range(3, stars.n):
        _enumerate_ending(stars, d, out)
    quads = _as_quads(out)
    return quads, _quads_edges(rules, stars, quads)
