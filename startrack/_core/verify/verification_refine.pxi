# The first test of a hypothesis, the refinement of an accepted one, its final labelling
# and what it reports (included in verification.pyx).


cdef FirstTest _fit_hypothesis(Frame frame, const long long[::1] hyp_obs,
                               const double[:, :] hyp_sky, double cos_radius):
    """A hypothesis (observed ``hyp_obs[k]`` is the catalog vector ``hyp_sky[k]``): its
    Wahba attitude, and whether each of its pairs lies within the match radius
    (``cos_radius``) of the other there."""
    cdef Py_ssize_t m = hyp_obs.shape[0], k
    cdef double[:, ::1] cam = _cam_rows(frame, m)
    for k in range(m):
        cam[k, 0], cam[k, 1], cam[k, 2] = (frame.vectors[hyp_obs[k], 0],
                                           frame.vectors[hyp_obs[k], 1],
                                           frame.vectors[hyp_obs[k], 2])
    cdef FirstTest test = FirstTest.__new__(FirstTest)
    test.matrix = empty_rows(3, 3)
    wahba(cam, hyp_sky, test.matrix)
    test.fits = fits_within(cam, hyp_sky, test.matrix, cos_radius)
    test.confirmed = 0
    return test


cdef FirstTest first_match(Frame frame, const long long[::1] hyp_obs,
                           const double[:, :] hyp_sky, Stars stars, double radius,
                           double cos_radius):
    """The first test of a hypothesis (:func:`_fit_hypothesis`); when it fits, the Stars
    matched to the frame at its attitude and how many matches lie outside it."""
    cdef FirstTest test = _fit_hypothesis(frame, hyp_obs, hyp_sky, cos_radius)
    if test.fits:
        test.matches = match(frame, stars.vectors, test.matrix, radius)
        test.confirmed = _confirmed(test.matches, hyp_obs)
    return test


cdef class _Refined:
    """A refinement's matches and attitude, and the Stars projected at that attitude when
    the refinement ended on it (else None: the labelling projects again)."""
    cdef Matches matches
    cdef double[:, ::1] matrix
    cdef Projection projection


cdef _Refined _refine(Frame frame, const double[:, ::1] vectors, double radius,
                      double capture, Matches start, Py_ssize_t max_rounds):
    """Refit on every matched star and match again until the matched set stops changing;
    when a plain refit changes nothing, refit once on the matches within ``capture``
    match radii and keep that only if it then matches more stars (a hypothesis with one
    star a few pixels off, far from the others, can pass with the rest of the frame
    turned beyond the match radius, where a plain refit never sees it)."""
    cdef _Refined out = _Refined.__new__(_Refined)
    cdef Matches cur = start, new, wide
    cdef Projection p = None
    cdef bint projected = False, changed
    cdef Py_ssize_t rounds
    cdef double[:, ::1] matrix = _fit(frame, cur.obs, vectors, cur.pos)
    for rounds in range(max_rounds):
        p = _project_into(frame.work.kept, vectors, matrix, frame.geometry)
        projected = True
        new = _match_pair(frame, p, radius, capture * radius)
        changed = new.obs.shape[0] > cur.obs.shape[0] or (
            new.obs.shape[0] == cur.obs.shape[0] and not _same(new, cur))
        if not changed:
            wide = _wide_claimed(frame, p, capture * radius)
            if wide.obs.shape[0] < 2 or _same(wide, cur):
                break  # the same pairs refit to the same attitude: nothing would change
            new = match(frame, vectors, _fit(frame, wide.obs, vectors, wide.pos),
                        radius)
            if new.obs.shape[0] <= cur.obs.shape[0]:
                break
        cur = new
        matrix = _fit(frame, cur.obs, vectors, cur.pos)
        projected = False
    out.matches, out.matrix, out.projection = cur, matrix, p if projected else None
    return out


cdef Labelled _label_at(Frame frame, Stars stars, double[:, ::1] matrix,
                        Projection projection, Matches fitted, CheckParams params):
    """The final labelling at ``matrix`` (the Stars' ``projection`` there, or None) and
    the attitude refitted to the labels when there are three or more. ``fitted``: the
    pairs whose fit ``matrix`` is (None: unknown); labels that are those pairs refit to
    it bit for bit, so the fit is not repeated."""
    if projection is None:
        projection = _project_into(frame.work.kept, stars.vectors, matrix, frame.geometry)
    cdef _Selection s = _select(projection, frame.geometry, params.radius_px, frame.work)
    cdef Py_ssize_t m = s.where.shape[0], k
    frame.work.mags = room_f64(frame.work.mags, m)
    cdef double[::1] mags = frame.work.mags[:m]
    for k in range(m):
        mags[k] = stars.mags[s.where[k]]
    cdef Labels labels = label(frame.x, frame.y, s.x, s.y, mags, s.where, frame.flux,
                               params.label, frame.scratch)
    cdef Labelled out = Labelled.__new__(Labelled)
    out.obs, out.pos, out.refined, out.final = labels.obs, labels.cat, matrix, matrix
    if labels.obs.shape[0] >= 3 and not _same_pairs(labels.obs, labels.cat, fitted):
        out.final = _fit(frame, labels.obs, stars.vectors, labels.cat)
    return out


cdef Labelled refine_and_label(Frame frame, Stars stars, Matches start, CheckParams params,
                               Py_ssize_t max_rounds):
    """An accepted hypothesis's matches ``start`` refined (at most ``max_rounds``), the
    stars labelled at the refined attitude and the attitude refitted to the labels."""
    cdef _Refined r = _refine(frame, stars.vectors, params.radius_px, params.capture, start,
                              max_rounds)
    return _label_at(frame, stars, r.matrix, r.projection, r.matches, params)


cdef double[::1] residual_arcsec(const double[:, ::1] obs_vectors, const long long[::1] obs,
                                 const double[:, :] matrix, const double[:, :] cat_vectors):
    """Angle (arcseconds) between each observed star ``obs[k]`` rotated to the sky by
    ``matrix`` (camera to sky) and its catalog vector ``cat_vectors[k]``."""
    out = empty_f64(obs.shape[0])
    _residuals_into(obs_vectors, obs, matrix, cat_vectors, <double*>cnp.PyArray_DATA(out))
    return out


cdef void _residuals_into(const double[:, ::1] obs_vectors, const long long[::1] obs,
                          const double[:, :] matrix, const double[:, :] cat_vectors,
                          double* out) noexcept:
    """residual_arcsec written into ``out`` (a pointer: the numpy array's typed view would
    cost more than a frame's arithmetic)."""
    cdef Py_ssize_t k
    cdef int i
    cdef double dot
    for k in range(obs.shape[0]):
        dot = 0.0
        for i in range(3):
            dot += (matrix[i, 0] * obs_vectors[obs[k], 0]
                    + matrix[i, 1] * obs_vectors[obs[k], 1]
                    + matrix[i, 2] * obs_vectors[obs[k], 2]) * cat_vectors[k, i]
        out[k] = acos(fmax(-1.0, fmin(1.0, dot))) * _ARCSEC
