# The camera fitted to identified stars (implemented in fit.pyx), for C callers: the
# fitted rounds of fitted_rounds.pyx run it once per round.

from startrack._core.camera.lens cimport Geometry

cdef enum:
    # what the fit ended on: settled (or out of iterations), a focal length not positive
    # and finite, a fitted k1 folding back inside the image
    _SETTLED = 0
    _BAD_FOCAL = 1
    _FOLDS = 2


cdef int fit_geometry(const Geometry* g, const double[::1] x, const double[::1] y,
                      const double[:, ::1] cat, int iterations, bint with_k1,
                      double min_r2, double max_k1, double k1_chi2, double* f_out,
                      double* k1_out)


cdef void fitted_lens(Geometry* g, double k1) noexcept nogil


cdef double focal_spread(const Geometry* g, const double[::1] x, const double[::1] y,
                         const double[:, ::1] cat)
