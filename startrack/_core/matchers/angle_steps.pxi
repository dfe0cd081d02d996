# The angle search's steps on one frame (included by angle.pyx): the pair lookups and
# their groupings, the joins and pivots, and the triangles of a chain's first pair, kept
# for the chains that share it.


cdef inline void _touch(AngleFrame f, Py_ssize_t p, Py_ssize_t q) noexcept:
    """Count the first lookup of the observed pair {p, q} as database candidates."""
    cdef Py_ssize_t a = min(p, q), b = max(p, q)
    if not f.seen[a, b]:
        f.seen[a, b] = True
        f.candidates += f.windows[p, q, 1] - f.windows[p, q, 0]
        f.lookups += 1


cdef inline bint _empty(AngleFrame f, Py_ssize_t p, Py_ssize_t q) noexcept:
    return f.windows[p, q, 1] <= f.windows[p, q, 0]


cdef inline void _event(AngleFrame f, bint ambiguous) noexcept:
    if not f.any_event:
        f.any_event, f.ambiguous_first = True, ambiguous


cdef object _first_pairs(AngleFrame f, Py_ssize_t p, Py_ssize_t q):
    """The catalog pairs of (p, q) as rows (star of p, star of q): the window in table
    order one way round, then the other."""
    cdef Py_ssize_t s0 = f.windows[p, q, 0], s1 = f.windows[p, q, 1], w = max(s1 - s0, 0), e
    out = np.empty((2 * w, 2), np.int64)
    cdef long long[:, ::1] rows = out
    cdef long long i, j
    for e in range(s0, s1):
        if p > q:
            i, j = f.pj[e], f.pi[e]
        else:
            i, j = f.pi[e], f.pj[e]
        rows[e - s0, 0], rows[e - s0, 1] = i, j
        rows[w + e - s0, 0], rows[w + e - s0, 1] = j, i
    return out


cdef Py_ssize_t _grouped(AngleFrame f, Py_ssize_t p, Py_ssize_t q) noexcept:
    """The window of (p, q) grouped per star of p (group_window), built once per frame:
    its key into ``heads`` and ``offsets``."""
    cdef Py_ssize_t k = p * f.n + q, o0 = f.offsets[k], o1 = f.offsets[k + 1]
    if not f.done[k]:
        f.done[k] = True
        f.heads[k, :] = -1
        group_window(f.pi, f.pj, f.windows[p, q, 0], f.windows[p, q, 1], p > q, f.heads[k],
                     f.nxt[o0:o1], f.val[o0:o1])
    return k


cdef tuple _extend(AngleFrame f, const long long[:, :] hyps, Py_ssize_t col, Py_ssize_t p,
                   Py_ssize_t q, Py_ssize_t max_rows):
    """join_extend on the window of (p, q): (rows, total)."""
    _touch(f, p, q)
    if _empty(f, p, q):
        return np.zeros((0, hyps.shape[1] + 1), np.int64), 0
    cdef Py_ssize_t k = _grouped(f, p, q), o0 = f.offsets[k], o1 = f.offsets[k + 1]
    return join_extend_rows(hyps, col, f.heads[k], f.nxt[o0:o1], f.val[o0:o1], max_rows)


cdef object _close(AngleFrame f, object hyps, Py_ssize_t col_p, Py_ssize_t col_q,
                   Py_ssize_t p, Py_ssize_t q):
    """join_close on the window of (p, q): the same pair set either way round, so an
    existing grouping of (q, p) serves."""
    _touch(f, p, q)
    if _empty(f, p, q):
        return hyps[:0]
    if f.done[q * f.n + p]:
        p, q = q, p
    cdef Py_ssize_t k = _grouped(f, p, q), o0 = f.offsets[k], o1 = f.offsets[k + 1]
    return join_close_rows(hyps, col_p, col_q, f.heads[k], f.nxt[o0:o1], f.val[o0:o1])


cdef bint _stops(AngleFrame f, long long total, Py_ssize_t n_rows) noexcept:
    """Whether a pivot's closing pairs stop here: budget spent, too many or no rows, or
    one row left and the rule is to close until one is."""
    return f.budget <= 0 or total > f.limits.max_rows or n_rows == 0 or (
        n_rows == 1 and f.limits.closing == _UNTIL_ONE)


cdef tuple _pivot(AngleFrame f, object hyps, const long long[::1] cols, Py_ssize_t n_cols,
                  Py_ssize_t q):
    """One pivot to star q: the join on (newest chain star, q), then the closing pairs (q,
    earlier chain star) while the closing rule asks for them. (rows, total)."""
    f.budget -= 1
    f.pivots += 1
    rows, total = _extend(f, hyps, n_cols - 1, cols[n_cols - 1], q, f.limits.max_rows + 1)
    cdef Py_ssize_t col_t
    for col_t in range(n_cols - 1 if f.limits.closing != _NONE else 0):
        if _stops(f, total, len(rows)):
            break
        f.budget -= 1
        f.pivots += 1
        rows = _close(f, rows, n_cols, col_t, q, cols[col_t])
    return rows, total


cdef tuple _joined(AngleFrame f, Py_ssize_t a, Py_ssize_t b, Py_ssize_t q, object pairs):
    """The pair rows of (a, b) (built if ``pairs`` is still None) joined on (b, q):
    (rows, total, pairs)."""
    if pairs is None:
        pairs = _first_pairs(f, a, b)
    rows, total = _extend(f, pairs, 1, b, q, f.limits.max_rows + 1)
    return rows, total, pairs


cdef tuple _triangles(AngleFrame f, Py_ssize_t a, Py_ssize_t b, Py_ssize_t q):
    """The pair rows of (a, b) joined on (b, q) and narrowed by (q, a) without the rows
    in between: (rows, rows joined on (b, q)). Counts nothing."""
    if _empty(f, b, q):
        return np.empty((0, 3), np.int64), 0
    cdef Py_ssize_t k = _grouped(f, b, q), o0 = f.offsets[k], o1 = f.offsets[k + 1], kc
    cdef int[::1] head = f.heads[k], nxt = f.nxt[o0:o1], val = f.val[o0:o1]
    cdef int[::1] c_head = head, c_nxt = nxt, c_val = val
    cdef bint closes = not _empty(f, q, a)
    if closes:
        kc = _grouped(f, a, q) if f.done[a * f.n + q] else _grouped(f, q, a)
        c_head, c_nxt = f.heads[kc], f.nxt[f.offsets[kc]:f.offsets[kc + 1]]
        c_val = f.val[f.offsets[kc]:f.offsets[kc + 1]]
    out = np.empty((16, 3), np.int64)
    cdef long long[:, ::1] rows = out
    cdef Py_ssize_t m = 0, total = 0, e, p
    cdef int half, x, y, z
    for half in range(2):  # _first_pairs' order
        for e in range(f.windows[a, b, 0], f.windows[a, b, 1]):
            if (a > b) == (half == 0):
                x, y = f.pj[e], f.pi[e]
            else:
                x, y = f.pi[e], f.pj[e]
            p = head[y]
            while p >= 0:
                z = val[p]
                p = nxt[p]
                if z == x or z == y:
                    continue
                total += 1
                if closes and linked(c_head, c_nxt, c_val, z, x):
                    if m == rows.shape[0]:
                        out = np.concatenate((out, np.empty_like(out)))
                        rows = out
                    rows[m, 0], rows[m, 1], rows[m, 2] = x, y, z
                    m += 1
    return out[:m], total


cdef tuple _pair_step(AngleFrame f, Py_ssize_t a, Py_ssize_t b, Py_ssize_t q, object pairs):
    """:func:`_pivot` from the chain's first pair (a, b) to q: the triangles (a, b, q),
    which the chains that share a first pair ask for again and again. Their counts, and
    their rows while they fit into the frame's store, are kept for the frame; the
    counters advance as if each were found anew. ``pairs`` are the pair rows, None until
    a pivot needs them. Returns (rows, total, pairs)."""
    cdef Py_ssize_t key = (a * f.n + b) * f.n + q, max_rows = f.limits.max_rows
    f.budget -= 1
    f.pivots += 1
    _touch(f, b, q)
    if f.limits.closing == _NONE:
        return _joined(f, a, b, q, pairs)
    closed = np.zeros((0, 3), np.int64)
    cdef bint found = f.info[key, 0] == 0
    if found:
        closed, total = _triangles(f, a, b, q)
        f.info[key, 0], f.info[key, 1], f.info[key, 2] = 1, min(total, max_rows + 1), total
        if f.fill + len(closed) <= STORE_ROWS:
            f.info[key, 0], f.info[key, 3], f.info[key, 4] = 2, f.fill, len(closed)
            f.store[f.fill:f.fill + len(closed)] = closed
            f.fill += len(closed)
    cdef long long n_ext = f.info[key, 1]
    total = f.info[key, 2]
    if _stops(f, total, n_ext):
        if total > max_rows or n_ext == 0:  # the chain leaves q out: no rows needed
            return closed[:0], total, pairs
        ext, _, pairs = _joined(f, a, b, q, pairs)
        return ext, total, pairs
    f.budget -= 1
    f.pivots += 1
    _touch(f, q, a)
    if f.info[key, 0] == 2:
        return f.store[f.info[key, 3]:f.info[key, 3] + f.info[key, 4]], total, pairs
    if not found:
        closed, _ = _triangles(f, a, b, q)
    return closed, total, pairs
