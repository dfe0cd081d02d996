# The vote of a tracked frame (included in tracked_frame.pyx): the observed stars paired with the
# catalog stars projected at the prediction, and the pairs that agree on one image
# displacement; and the catalog rows a turn can bring into the image.


cdef class Consistent:
    """The pairs that agree on one displacement (observed index ``obs``, held-row
    position ``pos``), nearest the winning displacement first, and how many pairs the
    window held (``n_pairs``)."""
    cdef long long[::1] obs
    cdef long long[::1] pos
    cdef Py_ssize_t n_pairs


cdef void _stable_order(const double[::1] key, long long[::1] order) noexcept nogil:
    """``order`` (0..n-1 on entry) sorted by ``key``, ties kept in place (insertion sort:
    a vote keeps a few dozen pairs)."""
    cdef Py_ssize_t i, j
    cdef long long t
    for i in range(1, order.shape[0]):
        t = order[i]
        j = i
        while j > 0 and key[order[j - 1]] > key[t]:
            order[j] = order[j - 1]
            j -= 1
        order[j] = t


cdef unsigned char[::1] _nearest_each(const long long[::1] oi, const long long[::1] ci,
                                      const double[::1] dx, const double[::1] dy,
                                      Py_ssize_t best, double tol, long long[::1] pick,
                                      double[::1] dist):
    """Per observed star, its pair nearest the displacement of pair ``best`` within
    ``tol`` px (``pick``, ``dist``: squared px), each catalog star kept once (nearest wins,
    ties: the lower observed index): which observed stars keep their pair."""
    cdef Py_ssize_t p = oi.shape[0], n_obs = pick.shape[0], n_cat = 0, j, o
    cdef double t2 = tol * tol, ddx, ddy, d
    for j in range(p):
        ddx, ddy = dx[best] - dx[j], dy[best] - dy[j]
        d = ddx * ddx + ddy * ddy
        if d <= t2 and d < dist[oi[j]]:
            pick[oi[j]], dist[oi[j]] = j, d
    for j in range(p):
        n_cat = max(n_cat, ci[j] + 1)
    cdef unsigned char[::1] keep = np.zeros(n_obs, np.uint8)
    cdef long long[::1] owner = np.full(n_cat, -1, np.int64)  # per catalog star, its star
    cdef long long c
    for o in range(n_obs):
        if pick[o] < 0:
            continue
        c = ci[pick[o]]
        if owner[c] < 0 or dist[o] < dist[owner[c]]:  # the nearer keeps it; ties: earlier
            if owner[c] >= 0:
                keep[owner[c]] = 0
            owner[c], keep[o] = o, 1
    return keep


cdef long long[::1] _vote(const long long[::1] oi, const long long[::1] ci,
                          const double[::1] dx, const double[::1] dy, double vote_tol,
                          double tol, Py_ssize_t centres):
    """Indices of the pairs that agree on one displacement: among the pairs of the
    ``centres`` brightest observed stars, the one whose displacement the most distinct
    observed stars share within ``vote_tol`` px (ties: the smaller displacement), then,
    within ``tol`` px of it, per observed star the pair nearest it, each catalog star once
    (nearest wins, ties: the lower observed index); sorted by the distance of their
    displacement from the winner's. ``oi`` ascending, at least one pair."""
    cdef Py_ssize_t p = oi.shape[0], n_obs = oi[p - 1] + 1, i, j, o, n_keep = 0
    cdef double v2 = vote_tol * vote_tol, d, best_d = np.inf, ddx, ddy
    cdef long long[::1] seen = np.full(n_obs, -1, np.int64)
    cdef Py_ssize_t best = -1, best_votes = -1, votes
    # The true displacement is shared by nearly every real star's pair, so the brightest
    # stars' pairs hold it: trying only those as centres bounds the vote at O(centres p).
    for i in range(p):
        if oi[i] >= centres:
            break
        votes = 0
        for j in range(p):
            ddx, ddy = dx[i] - dx[j], dy[i] - dy[j]
            if ddx * ddx + ddy * ddy <= v2 and seen[oi[j]] != i:
                seen[oi[j]] = i
                votes += 1
        d = dx[i] * dx[i] + dy[i] * dy[i]
        if votes > best_votes or (votes == best_votes and d < best_d):
            best, best_votes, best_d = i, votes, d
    if best < 0:
        return np.zeros(0, np.int64)
    cdef long long[::1] pick = np.full(n_obs, -1, np.int64)
    cdef double[::1] dist = np.full(n_obs, np.inf)
    cdef unsigned char[::1] keep = _nearest_each(oi, ci, dx, dy, best, tol, pick, dist)
    cdef long long[::1] chosen = np.empty(n_obs, np.int64), order
    cdef double[::1] key = np.empty(n_obs)
    for o in range(n_obs):
        if keep[o]:
            chosen[n_keep], key[n_keep] = pick[o], dist[o]
            n_keep += 1
    # Nearest the winning displacement first: true pairs cluster there, chance pairs
    # inside a wide window spread over it.
    order = np.arange(n_keep, dtype=np.int64)
    _stable_order(key[:n_keep], order)
    for o in range(n_keep):
        order[o] = chosen[order[o]]
    return order


cdef Consistent _consistent_pairs(const double[:, ::1] vectors, const double[:, :] matrix,
                                  const double[::1] ox, const double[::1] oy, Geometry g,
                                  double window, double vote_tol, double tol,
                                  Py_ssize_t centres):
    """Every (observed, held row) pair within ``window`` px at ``matrix``, then the
    consistent ones (:func:`_vote`; the vote needs three pairs)."""
    cdef Projection proj = project(vectors, matrix, g)
    cdef unsigned char[::1] inside = within(proj, g, window)
    cdef Py_ssize_t n = vectors.shape[0], n_sel = 0, i, k
    cdef long long[::1] sel = np.empty(n, np.int64)
    for i in range(n):
        if inside[i]:
            sel[n_sel] = i
            n_sel += 1
    cdef double[::1] px = np.empty(n_sel), py = np.empty(n_sel)
    for i in range(n_sel):
        px[i], py[i] = proj.x[sel[i]], proj.y[sel[i]]
    cdef Pairs pairs = pairs_within(ox, oy, px, py, window * window)
    cdef Py_ssize_t p = pairs.obs.shape[0]
    cdef long long[::1] cj = np.empty(p, np.int64)
    cdef double[::1] dx = np.empty(p), dy = np.empty(p)
    for k in range(p):
        cj[k] = sel[pairs.cat[k]]
        dx[k], dy[k] = proj.x[cj[k]] - ox[pairs.obs[k]], proj.y[cj[k]] - oy[pairs.obs[k]]
    cdef Consistent out = Consistent.__new__(Consistent)
    out.n_pairs = p
    cdef long long[::1] keep = (np.zeros(0, np.int64) if p < 3
                                else _vote(pairs.obs, cj, dx, dy, vote_tol, tol, centres))
    out.obs, out.pos = np.empty(keep.shape[0], np.int64), np.empty(keep.shape[0], np.int64)
    for k in range(keep.shape[0]):
        out.obs[k], out.pos[k] = pairs.obs[keep[k]], cj[keep[k]]
    return out


cdef long long[:, ::1] _triples(Py_ssize_t n, Py_ssize_t limit):
    """The first ``limit`` index triples of ``range(n)`` in itertools.combinations
    order."""
    cdef long long[:, ::1] out = np.empty((max(limit, 0), 3), np.int64)
    cdef Py_ssize_t a, b, c, h = 0
    for a in range(n):
        for b in range(a + 1, n):
            for c in range(b + 1, n):
                if h == limit:
                    return out
                out[h, 0], out[h, 1], out[h, 2] = a, b, c
                h += 1
    return out[:h]


def consistent_pairs(const double[:, ::1] vectors, prior_matrix, const double[::1] ox,
                     const double[::1] oy, double sigma, TrackSetup setup):
    """The consistent pairs :func:`attempt` draws its hypotheses from, for the observed
    stars ``ox``, ``oy`` and the catalog ``vectors`` at the prediction (1-sigma ``sigma``
    rad): (observed index, vector position, pairs in the window)."""
    cdef const double[:, ::1] prior = np.ascontiguousarray(prior_matrix, dtype=np.float64)
    cdef TrackParams* p = &setup.params
    cdef double tol = setup.keep_px(sigma)
    cdef Consistent c = _consistent_pairs(
        vectors, prior, ox, oy, setup.geometry, setup.window_px(sigma),
        min(tol, p.vote_radii * p.check.radius_px), tol, p.vote_centres)
    return np.asarray(c.obs), np.asarray(c.pos), c.n_pairs


def nearby(const double[:, ::1] vectors, matrix_in, Optics optics, double margin):
    """Positions of the vectors in the image widened by ``margin`` px at the attitude
    ``matrix_in``, and of any the lens model cannot place there (beyond its fold radius:
    kept, since a turn could bring them in)."""
    cdef const double[:, ::1] m = np.ascontiguousarray(matrix_in, dtype=np.float64)
    cdef Geometry g = _geometry(optics)
    cdef unsigned char[::1] inside = within(project(vectors, m, g), g, margin)
    cdef Py_ssize_t i
    cdef double vx, vy, vz
    if isfinite(g.max_r2):
        for i in range(vectors.shape[0]):
            vx = vectors[i, 0] * m[0, 0] + vectors[i, 1] * m[1, 0] + vectors[i, 2] * m[2, 0]
            vy = vectors[i, 0] * m[0, 1] + vectors[i, 1] * m[1, 1] + vectors[i, 2] * m[2, 1]
            vz = vectors[i, 0] * m[0, 2] + vectors[i, 1] * m[1, 2] + vectors[i, 2] * m[2, 2]
            if vz > 1e-12 and not (vx * vx + vy * vy) / (vz * vz) < g.max_r2:
                inside[i] = 1
    return np.flatnonzero(np.asarray(inside))
