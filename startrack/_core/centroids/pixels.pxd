# The centroider's pixel rows: the frame (any dtype it is read in) minus the sky model,
# evaluated on the fly, and its smoothed detection rows. No full-size float copy of the
# frame, background or residual is ever made.

from libc.math cimport isfinite
from libc.stdint cimport int16_t, uint8_t, uint16_t

# The dtypes a frame is read in as it is (others are converted to float64 first).
ctypedef fused pixel_t:
    uint8_t
    uint16_t
    int16_t
    float
    double


cdef struct PixelSky:
    # The sky model at the pixels: tile rows interpolated along the columns (tile rows x
    # W, row-major) and, per pixel row, the two tile rows to blend and the second's weight.
    const double* rows
    Py_ssize_t width
    const long long* row_lo
    const long long* row_hi
    const double* row_t


cdef inline double background_at(const PixelSky* sky, Py_ssize_t r,
                                 Py_ssize_t c) noexcept nogil:
    """The sky model at pixel (r, c)."""
    cdef double t = sky.row_t[r]
    return (sky.rows[sky.row_lo[r] * sky.width + c] * (1.0 - t)
            + sky.rows[sky.row_hi[r] * sky.width + c] * t)


cdef inline void residual_row(const pixel_t[:, ::1] image, const PixelSky* sky, Py_ssize_t r,
                              double[::1] out) noexcept nogil:
    """Row ``r`` of the frame minus the sky model into ``out``; a non-finite pixel's
    residual is 0."""
    cdef const double* lo = sky.rows + sky.row_lo[r] * sky.width
    cdef const double* hi = sky.rows + sky.row_hi[r] * sky.width
    cdef double t = sky.row_t[r], v
    cdef Py_ssize_t c
    if pixel_t is float or pixel_t is double:
        for c in range(out.shape[0]):
            v = <double>image[r, c]
            out[c] = v - (lo[c] * (1.0 - t) + hi[c] * t) if isfinite(v) else 0.0
    else:  # an integer is finite: no test, and the loop vectorises
        for c in range(out.shape[0]):
            out[c] = <double>image[r, c] - (lo[c] * (1.0 - t) + hi[c] * t)


cdef inline Py_ssize_t reflect101(Py_ssize_t i, Py_ssize_t n) noexcept nogil:
    """Index ``i`` reflected into [0, n) without repeating the edge (cv2's BORDER_REFLECT_101)."""
    if n == 1:
        return 0
    if i < 0:
        return -i
    if i >= n:
        return 2 * n - 2 - i
    return i


cdef inline void _smooth_row(const double[::1] above, const double[::1] mid,
                             const double[::1] below, double[::1] vbuf,
                             double[::1] out) noexcept nogil:
    """3 x 3 Gaussian ([1, 2, 1] / 4 each way, reflect-101 borders, as cv2.GaussianBlur)."""
    cdef Py_ssize_t c, w = mid.shape[0]
    for c in range(w):
        vbuf[c] = 0.25 * above[c] + 0.5 * mid[c] + 0.25 * below[c]
    if w == 1:
        out[0] = vbuf[0]
        return
    for c in range(1, w - 1):  # no border test inside: the loop vectorises
        out[c] = 0.25 * vbuf[c - 1] + 0.5 * vbuf[c] + 0.25 * vbuf[c + 1]
    out[0] = 0.5 * vbuf[0] + 0.5 * vbuf[1]
    out[w - 1] = 0.5 * vbuf[w - 1] + 0.5 * vbuf[w - 2]


cdef inline Py_ssize_t detection_row(const pixel_t[:, ::1] image, const PixelSky* sky,
                                     Py_ssize_t r, Py_ssize_t first, double[:, ::1] ring,
                                     double[::1] vbuf, double[::1] out,
                                     bint smooth) noexcept nogil:
    """The detection image's row ``r`` (smoothed residual, or the residual itself) into
    ``out``; returns the row of ``ring`` that holds the residual row ``r``.

    ``ring`` (3 x W) holds residual rows r - 1, r and r + 1 at row % 3, and is advanced
    here by one row: call for r = first, first + 1, ... in order."""
    cdef Py_ssize_t h = image.shape[0], c
    if r == first:
        residual_row(image, sky, r, ring[r % 3])
        if r > 0:
            residual_row(image, sky, r - 1, ring[(r - 1) % 3])
    if r + 1 < h:
        residual_row(image, sky, r + 1, ring[(r + 1) % 3])
    if not smooth:
        for c in range(out.shape[0]):
            out[c] = ring[r % 3, c]
        return r % 3
    _smooth_row(ring[reflect101(r - 1, h) % 3], ring[r % 3], ring[reflect101(r + 1, h) % 3],
                vbuf, out)
    return r % 3
