# The final labelling (implemented in labelling.pyx): which observed star is reported as
# which catalog star at an accepted attitude (the rules: startrack.verify._labelling).

from startrack._core.verify.nearest cimport NearestScratch


cdef struct LabelParams:
    # The thresholds of startrack.verify._labelling.LabelConfig as the kernel takes them, for one
    # frame (startrack.verify._labelling.label_params builds them).
    bint has_flux           # the frame's stars carry fluxes (else brightness is not used)
    double radius2          # the match radius, squared (px^2)
    double sigma0           # the frame's stated centroid noise (px)
    double area             # the image's area (px^2)
    double log_gap          # log of the ambiguity ratio
    double log_false_odds   # log of the false-star odds allowed
    double resolve2         # catalog stars closer than this (squared px) are one spot
    double mag_sigmas       # brightness consistency limit, in fitted scatters
    double min_mag_sigma    # floor of the fitted brightness scatter (mag)
    double min_sigma_px     # floor of the fitted residual scatter (px)
    Py_ssize_t min_fit      # isolated pairs needed to fit the scatters


cdef class Labels:
    """The reported pairs (``obs`` ascending, ``cat`` taken from the rows passed in), the
    withheld counts by reason (brightness, unresolved, ambiguous, coincidence), the fitted
    residual scatter, the fitted brightness scatter and whether brightness was used."""
    cdef long long[::1] obs
    cdef long long[::1] cat
    cdef long long[4] withheld
    cdef double sigma_px
    cdef double mag_sigma
    cdef bint used


cdef Labels label(const double[::1] ox, const double[::1] oy, const double[::1] x,
                  const double[::1] y, const double[::1] mag, const long long[::1] rows,
                  const double[::1] flux, LabelParams params, NearestScratch scratch=*)
