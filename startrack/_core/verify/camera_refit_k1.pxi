# Whether the pairs support a k1 other than the camera's (included in camera_refit.pyx,
# after the fit's scratch): the score test that lets the refit skip the rounds that free
# k1 where freeing it would move the fit by less than the noise.


cdef bint _k1_unsupported(const Fit* fit, Py_ssize_t rows, double chi2) noexcept nogil:
    """Whether the pairs give k1 no support at the fit that held it: its efficient score
    (J^T r for k1, less what the other six parameters explain) squared, over the
    residuals' variance times k1's information left after those six (a Schur complement
    of J^T J, their block solved with the columns scaled to unit length, as the fit's
    steps solve it), is within ``chi2``. False where that cannot be told (too few
    residuals, a singular block, no information left)."""
    cdef double a[NP * NP]
    cdef double b[NP]
    cdef double scale[NP]
    cdef double info, score, variance
    cdef int i, j, k1 = NP - 1
    if rows - (NP - 1) <= 0 or not fit.r2 > 0.0:
        return False
    variance = fit.r2 / (rows - (NP - 1))
    for i in range(NP):
        scale[i] = 1.0 / sqrt(fit.jtj[i * NP + i]) if fit.jtj[i * NP + i] > 0.0 else 1.0
    for i in range(NP):
        for j in range(NP):
            a[i * NP + j] = (fit.jtj[i * NP + j] * scale[i] * scale[j] if i < k1 and j < k1
                             else (1.0 if i == j else 0.0))
        a[i * NP + i] += 1e-12
        b[i] = fit.jtj[i * NP + k1] * scale[i] if i < k1 else 0.0
    if not _solve(a, b):
        return False
    info, score = fit.jtj[k1 * NP + k1], fit.jtr[k1]
    for i in range(k1):
        info -= fit.jtj[k1 * NP + i] * scale[i] * b[i]
        score -= fit.jtr[i] * scale[i] * b[i]
    if not info > 0.0:
        return False
    return score * score <= chi2 * variance * info


def k1_score(const double[::1] p, const double[:, ::1] v, const double[::1] x,
             const double[::1] y, const long long[::1] spots, const long long[::1] stars,
             double chi2):
    """:func:`_k1_unsupported` of the pairs ``spots`` -> ``stars`` at ``p`` (its tests
    hold it to the chi-square of numpy's least squares)."""
    cdef Py_ssize_t n = spots.shape[0], i
    cdef _Work work = _Work(x.shape[0], v.shape[0])
    for i in range(n):
        work.spot[i], work.star[i] = spots[i], stars[i]
    _jacobian(&p[0], v, x, y, work.spot, work.star, n, work.fit.r, work.fit.jac)
    _normal(&work.fit, 2 * n)
    work.fit.r2 = _sum_squares(work.fit.r, 2 * n)
    return _k1_unsupported(&work.fit, 2 * n, chi2)
