# The scatters the final labelling fits to a frame (included in labelling.pyx): the
# isolated pairs, the residual scatter and the brightness fit.


cdef class _Fit:
    """The brightness fit: per pair whether it is consistent in brightness and its
    log-likelihood ratio, the fitted scatter and whether brightness is used."""
    cdef unsigned char[::1] ok
    cdef double[::1] log_b
    cdef double sigma
    cdef bint used


@cython.cdivision(True)  # x / 0 is inf or NaN, as numpy's
cdef _Fit _brightness(Pairs pairs, const double[::1] flux, const double[::1] mag,
                      const long long[::1] iso_pair, LabelParams p, _Work w):
    cdef Py_ssize_t n_pairs = pairs.obs.shape[0], n_obs = flux.shape[0], i, k, n_fit = 0
    cdef _Fit fit = _Fit.__new__(_Fit)
    w.ok, w.log_b = room_u8(w.ok, n_pairs), room_f64(w.log_b, n_pairs)
    fit.ok, fit.log_b = _set_u8(w.ok, n_pairs, 1), _set_f64(w.log_b, n_pairs, 0.0)
    fit.sigma, fit.used = NAN, False
    if not p.has_flux:
        return fit
    w.inst = room_f64(w.inst, n_obs)
    cdef double[::1] inst = _set_f64(w.inst, n_obs, NAN)
    for i in range(n_obs):
        if isfinite(flux[i]) and flux[i] > 0.0:
            inst[i] = -2.5 * log10(flux[i])
    w.offset = room_f64(w.offset, iso_pair.shape[0])
    cdef double[::1] offset = w.offset[:iso_pair.shape[0]]
    for k in range(iso_pair.shape[0]):
        i = pairs.obs[iso_pair[k]]
        if not isnan(inst[i]):
            offset[n_fit] = inst[i] - mag[pairs.cat[iso_pair[k]]]
            n_fit += 1
    if n_fit < p.min_fit:
        return fit
    offset = offset[:n_fit]
    cdef double zero = median_inplace(offset)
    for k in range(n_fit):
        offset[k] = fabs(offset[k] - zero)
    cdef double sigma = _MAD_TO_SIGMA * median_inplace(offset)
    if p.min_mag_sigma > sigma:
        sigma = p.min_mag_sigma
    if mag.shape[0] == 0:  # as numpy's ptp of nothing
        raise ValueError("zero-size array to reduction operation maximum which has no identity")
    cdef double span = ptp(mag)
    if 2.0 * p.mag_sigmas * sigma > span:
        span = 2.0 * p.mag_sigmas * sigma
    if span == 0.0:  # as Python's float division
        raise ZeroDivisionError("float division by zero")
    cdef double norm = _log(sigma * sqrt(2.0 * M_PI) / span), limit = p.mag_sigmas * sigma
    cdef double off, t
    for k in range(n_pairs):
        i = pairs.obs[k]
        if not isnan(inst[i]):  # a usable flux
            off = fabs(inst[i] - mag[pairs.cat[k]] - zero)
            fit.ok[k] = off <= limit
            t = off / sigma
            fit.log_b[k] = -0.5 * (t * t) - norm
    fit.sigma, fit.used = sigma, True
    return fit


cdef long long[::1] _isolated(Pairs pairs, const long long[::1] per_cat, _Work w):
    """The pairs that are each other's only candidate, by observed index."""
    cdef Py_ssize_t n = pairs.start.shape[0] - 1, i, k = 0
    w.iso = room_i64(w.iso, n)
    cdef long long[::1] view = w.iso
    for i in range(n):
        if pairs.start[i + 1] - pairs.start[i] == 1 and per_cat[pairs.cat[pairs.start[i]]] == 1:
            view[k] = pairs.start[i]
            k += 1
    return view[:k]


cdef double _residual_sigma(Pairs pairs, const long long[::1] iso_pair, LabelParams p,
                            _Work w):
    """The residual scatter per axis: fitted over the isolated pairs when there are enough
    (the stated noise otherwise), floored at ``min_sigma_px``."""
    cdef double sigma = p.sigma0
    cdef Py_ssize_t k
    cdef double[::1] d2
    if iso_pair.shape[0] >= p.min_fit:
        w.d2 = room_f64(w.d2, iso_pair.shape[0])
        d2 = w.d2[:iso_pair.shape[0]]
        for k in range(iso_pair.shape[0]):
            d2[k] = pairs.d2[iso_pair[k]]
        sigma = sqrt(median_inplace(d2) * _MEDIAN_R2_TO_SIGMA2)
    if p.min_sigma_px > sigma:
        sigma = p.min_sigma_px
    return sigma
