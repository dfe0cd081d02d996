# One hypothesis checked in one call (included in verification.pyx): the first test, the
# binomial bound on a coincidence, the acceptance, the refinement, the labelling and
# what an accepted attitude reports.


@cython.cdivision(True)  # no divisor is zero once 0 < p < 1
cdef double binomial_tail(long long k, long long n, double p) noexcept nogil:
    """P(X > k) for X ~ Binomial(n, p), as ``scipy.special.bdtrc(k, n, p)`` over the range
    verification uses (0 <= k < n, 0 <= p <= 1), 0 where scipy's underflows: the largest
    term of the tail in log space, the others by their ratios, summed until negligible
    (the terms fall off on both sides of the binomial's mode)."""
    if k < 0:
        return 1.0
    if k >= n or p <= 0.0:
        return 0.0
    if p >= 1.0:
        return 1.0
    cdef double odds = p / (1.0 - p)
    cdef long long top = max(k + 1, min(n, <long long>((n + 1) * p)))  # the mode, or first
    cdef double log_top = (lgamma(n + 1.0) - lgamma(top + 1.0) - lgamma(n - top + 1.0)
                           + top * log(p) + (n - top) * log1p(-p))
    cdef double total = 1.0, ratio = 1.0
    cdef long long j
    for j in range(top, n):  # t(j + 1) / t(j) = (n - j) / (j + 1) * odds
        ratio *= (n - j) / (j + 1.0) * odds
        total += ratio
        if ratio <= 1e-17 * total:
            break
    ratio = 1.0
    for j in range(top, k + 1, -1):  # t(j - 1) / t(j) = j / ((n - j + 1) odds)
        ratio *= j / ((n - j + 1.0) * odds)
        total += ratio
        if ratio <= 1e-17 * total:
            break
    cdef double log_total = log_top + log(total)
    if log_total < _MIN_LOG:
        return 0.0
    return fmin(1.0, exp(log_total))


cdef bint _valid(const long long[::1] index, Py_ssize_t size) noexcept:
    """Whether ``index`` holds distinct values in [0, size) (a hypothesis has a few)."""
    cdef Py_ssize_t a, b
    for a in range(index.shape[0]):
        if index[a] < 0 or index[a] >= size:
            return False
        for b in range(a):
            if index[b] == index[a]:
                return False
    return True


cdef class Verdict:
    """One hypothesis checked (fields: ``verification.pxd``); its arrays are numpy arrays, made
    once by the check."""


# A refused verdict's pairs: empty, so one array serves them all.
cdef object _NO_PAIRS = zeros_i64(0)


cdef cnp.ndarray _matrix_array(const double[:, ::1] matrix):
    """A (3, 3) attitude as a new numpy array (what a Verdict hands Python)."""
    cdef cnp.ndarray out = empty_rows(3, 3)
    cdef double* p = <double*>cnp.PyArray_DATA(out)
    cdef int i, j
    for i in range(3):
        for j in range(3):
            p[3 * i + j] = matrix[i, j]
    return out


cdef Verdict _verdict(int status, first, Py_ssize_t cones):
    """A verdict with nothing matched; ``first``: the hypothesis's attitude (an array)."""
    cdef Verdict v = Verdict.__new__(Verdict)
    v.status, v.first, v.final, v.cones = status, first, first, cones
    v.obs = v.rows = _NO_PAIRS
    v.probability, v.confirmed = 1.0, 0
    v.residuals = v.quaternion = None
    return v


cdef FirstTest _first(Frame frame, const long long[::1] hyp_obs,
                      const long long[::1] hyp_rows, const double[:, ::1] catalog,
                      CheckParams params):
    """The hypothesis's attitude and whether each of its pairs fits (no match yet)."""
    cdef Py_ssize_t k
    cdef double[:, ::1] sky = _sky_rows(frame, hyp_rows.shape[0])
    for k in range(hyp_rows.shape[0]):
        sky[k, 0], sky[k, 1], sky[k, 2] = (catalog[hyp_rows[k], 0], catalog[hyp_rows[k], 1],
                                           catalog[hyp_rows[k], 2])
    return _fit_hypothesis(frame, hyp_obs, sky, params.cos_radius)


cdef Verdict _judge(Frame frame, const long long[::1] hyp_obs, double[:, ::1] first,
                    Stars stars, CheckParams params, _Cone cone):
    """Everything after the first attitude: the frame matched at it, the bound, the
    acceptance, then refinement, labelling, residuals and quaternion. ``cone``: where to
    look a fresh cone up when the refinement leaves this one's margin (None: fixed)."""
    cdef Verdict v = _verdict(NOT_ACCEPTED, _matrix_array(first), 0 if cone is None else 1)
    cdef Matches m = (match(frame, stars.vectors, first, params.radius_px)
                      if params.max_stars <= 0 else
                      match_brightest(frame, stars.vectors, first, params.radius_px,
                                      params.max_stars))
    cdef Py_ssize_t k, n = frame.n
    v.confirmed = _confirmed(m, hyp_obs)
    if v.confirmed > 0:
        v.probability = binomial_tail(
            v.confirmed - 1, n - hyp_obs.shape[0],
            fmin(1.0, m.n_in * M_PI * params.label.radius2 / params.label.area))
    if not (v.confirmed >= params.min_confirmed and v.probability <= params.max_probability):
        v.obs, v.rows = copy_i64(m.obs, m.obs.shape[0]), _take(stars.rows, m.pos)
        return v
    cdef _Refined r = _refine(frame, stars.vectors, params.radius_px, params.capture, m,
                              params.max_rounds)
    if cone is not None and _drift(r.matrix, first) < params.margin_cos:
        r, stars = _refine_on_fresh_cone(frame, r.matrix, params, cone, v)
    cdef Labelled done = _label_at(frame, stars, r.matrix, r.projection, r.matches, params)
    if done.obs.shape[0] < SMALLEST_HYPOTHESIS + params.min_confirmed:
        # the labelling withheld what the bound counted (residuals growing across the
        # frame, as a focal length a percent off makes them): not an answer, but its
        # matches tell a caller fitting the camera where to look again
        m = r.matches if r.matches is not None else match(frame, stars.vectors, r.matrix,
                                                          params.radius_px)
        v.status, v.final = UNLABELLED, _matrix_array(r.matrix)
        v.obs, v.rows = copy_i64(m.obs, m.obs.shape[0]), _take(stars.rows, m.pos)
        return v
    v.status = ACCEPTED
    report_labelled(v, frame, stars, done, True)
    return v


cdef void report_labelled(Verdict v, Frame frame, Stars stars, Labelled done,
                          bint accepted) except *:
    """``v``'s pairs (observed ascending, catalog rows) and final attitude from the
    labelling ``done``; once ``accepted``, what an accepted attitude reports: each star's
    residual (arcsec) and the final attitude's quaternion. New arrays, made through
    numpy's C API (numpy's functions cost a microsecond each)."""
    cdef Py_ssize_t k
    v.final = _matrix_array(done.final)
    v.obs, v.rows = copy_i64(done.obs, done.obs.shape[0]), _take(stars.rows, done.pos)
    if not accepted:
        return
    cdef double[:, ::1] cat = _sky_rows(frame, done.pos.shape[0])
    for k in range(done.pos.shape[0]):
        cat[k, 0], cat[k, 1], cat[k, 2] = (stars.vectors[done.pos[k], 0],
                                           stars.vectors[done.pos[k], 1],
                                           stars.vectors[done.pos[k], 2])
    v.residuals = empty_f64(done.obs.shape[0])
    _residuals_into(frame.vectors, done.obs, done.final, cat,
                    <double*>cnp.PyArray_DATA(v.residuals))
    v.quaternion = empty_f64(4)
    matrix_to_quaternion(done.final, v.quaternion)


cdef inline double _drift(const double[:, ::1] a, const double[:, ::1] b) noexcept:
    """The cosine between the boresights of attitudes ``a`` and ``b``."""
    return a[0, 2] * b[0, 2] + a[1, 2] * b[1, 2] + a[2, 2] * b[2, 2]


cdef cnp.ndarray _take(const long long[::1] rows, const long long[::1] pos):
    """``rows[pos]`` as an int64 array."""
    cdef cnp.ndarray out = empty_i64(pos.shape[0])
    cdef long long* view = <long long*>cnp.PyArray_DATA(out)
    cdef Py_ssize_t k
    for k in range(pos.shape[0]):
        view[k] = rows[pos[k]]
    return out


cdef class _Cone:
    """Where a check looks its catalog cones up: the cone table, every star's magnitude
    and the cone's radius."""
    cdef ConeTable table
    cdef const double[::1] mags
    cdef double radius

    cdef Stars around(self, const double[:, ::1] matrix, VerifyScratch work):
        """The Stars within the radius of ``matrix``'s boresight, in ``work``'s cone
        buffers (until its next call)."""
        cdef long long[::1] rows = cone_rows(self.table, matrix[:, 2], self.radius)
        return _gather(self.table.vectors, self.mags, rows, work)


cdef tuple _refine_on_fresh_cone(Frame frame, double[:, ::1] refined, CheckParams params,
                                 _Cone cone, Verdict v):
    """The refinement moved the boresight beyond the cone's margin (never by
    arcseconds): match and refine again on a cone around the refined attitude, and label
    on one around the final attitude if that moved beyond its margin too. Returns the
    refinement and the Stars to label."""
    cdef Stars stars = cone.around(refined, frame.work)
    cdef Matches m = match(frame, stars.vectors, refined, params.radius_px)
    cdef _Refined r = _refine(frame, stars.vectors, params.radius_px, params.capture, m,
                              params.max_rounds)
    v.cones += 1
    if _drift(r.matrix, refined) < params.margin_cos:
        stars = cone.around(r.matrix, frame.work)
        r.projection, r.matches = None, None  # positions in the Stars replaced
        v.cones += 1
    return r, stars


cdef Verdict check_fixed(Frame frame, const long long[::1] hyp_obs,
                         const long long[::1] hyp_rows, const double[:, ::1] catalog,
                         Stars stars, CheckParams params):
    """Verify one hypothesis (observed ``hyp_obs[k]`` is catalog row ``hyp_rows[k]`` of
    ``catalog``) over the given catalog Stars (rows fixed, e.g. around a prediction)."""
    if not (_valid(hyp_obs, frame.n) and _valid(hyp_rows, catalog.shape[0])) \
            or hyp_obs.shape[0] < 3 or hyp_obs.shape[0] != hyp_rows.shape[0]:
        return _verdict(BAD_INDEX, np.eye(3), 0)
    cdef FirstTest test = _first(frame, hyp_obs, hyp_rows, catalog, params)
    if not test.fits:
        return _verdict(REJECTED, _matrix_array(test.matrix), 0)
    return _judge(frame, hyp_obs, test.matrix, stars, params, None)


cdef Verdict check_cone(Frame frame, const long long[::1] hyp_obs,
                        const long long[::1] hyp_rows, ConeTable table,
                        const double[::1] mags, CheckParams params):
    """Verify one hypothesis on the catalog cone (``params.cone_radius``) around its
    attitude, the catalog's vectors in ``table`` and magnitudes in ``mags``."""
    if not (_valid(hyp_obs, frame.n) and _valid(hyp_rows, table.vectors.shape[0])) \
            or hyp_obs.shape[0] < 3 or hyp_obs.shape[0] != hyp_rows.shape[0]:
        return _verdict(BAD_INDEX, np.eye(3), 0)
    cdef FirstTest test = _first(frame, hyp_obs, hyp_rows, table.vectors, params)
    if not test.fits:
        return _verdict(REJECTED, _matrix_array(test.matrix), 0)
    cdef _Cone cone = _Cone.__new__(_Cone)
    cone.table, cone.mags, cone.radius = table, mags, params.cone_radius
    cdef Stars stars = cone.around(test.matrix, frame.work)
    return _judge(frame, hyp_obs, test.matrix, stars, params, cone)
