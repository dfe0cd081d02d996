"""The centroider's pixel passes: noise samples, the blob finder and the stars' moments.

Every pass reads the raw frame (uint8, uint16, int16, float32 or float64, as it is) and
evaluates the sky model (``SkyModel``, made from ``sky_blocks``' block means) on the fly.
``band_runs`` walks a band of rows and returns its runs of detected pixels with their
residual moments; bands are independent, so they run on threads at once (each call
releases the GIL). ``join_runs`` then joins the runs of all bands, in raster order, into
8-connected components (union-find) and sums their moments in that order: the same sums,
in the same order, however the frame was cut into bands.
"""

import numpy as np

from libc.math cimport INFINITY, isfinite
from libc.stdlib cimport free, malloc, realloc

from startrack._core.centroids.pixels cimport (PixelSky, background_at, detection_row, pixel_t,
                                      reflect101, residual_row)

# Columns of the per-run accumulator and of the components that ``join_runs`` returns.
cdef enum:
    SW, SWX, SWY, SWXX, SWXY, SWYY, FLUX, AREA, SAT, PEAK, PEAK_AT, N_ACC
    CHUNK = 32  # px, the unit in which rows are searched for detections

COLUMNS = {"sw": SW, "swx": SWX, "swy": SWY, "swxx": SWXX, "swxy": SWXY, "swyy": SWYY,
           "flux": FLUX, "area": AREA, "sat": SAT,
           "peak": PEAK, "peak_at": PEAK_AT}


cdef class SkyModel:
    """The sky model at the pixels: ``grid``, the tile values, blended bilinearly with the
    pixel ``Weights`` of ``sky_blocks`` (linear extrapolation at the border); ``rows``,
    each tile row interpolated along the columns, so that a model row is the blend of
    two of them."""

    cdef readonly object grid, rows, weights
    cdef PixelSky sky
    cdef const long long[::1] _row_lo, _row_hi
    cdef const double[::1] _row_t
    cdef const double[:, ::1] _rows

    def __init__(self, grid, weights):
        cdef const double[:, ::1] g = np.ascontiguousarray(grid, np.float64)
        cdef const long long[::1] c0 = weights.col_lo, c1 = weights.col_hi
        cdef const double[::1] fc = weights.col_t
        rows = np.empty((g.shape[0], c0.shape[0]))
        cdef double[:, ::1] out = rows
        cdef Py_ssize_t i, c
        for i in range(g.shape[0]):
            for c in range(c0.shape[0]):
                out[i, c] = g[i, c0[c]] * (1.0 - fc[c]) + g[i, c1[c]] * fc[c]
        self.grid, self.rows, self.weights = np.asarray(g), rows, weights
        self._rows, self._row_lo, self._row_hi = out, weights.row_lo, weights.row_hi
        self._row_t = weights.row_t
        self.sky.rows = &self._rows[0, 0]
        self.sky.width = out.shape[1]
        self.sky.row_lo = &self._row_lo[0]
        self.sky.row_hi = &self._row_hi[0]
        self.sky.row_t = &self._row_t[0]

    def image(self):
        """The sky model as a float32 image (for inspection and tests)."""
        out = np.empty((self._row_t.shape[0], self.sky.width), np.float32)
        cdef float[:, ::1] img = out
        cdef Py_ssize_t r, c
        for r in range(img.shape[0]):
            for c in range(img.shape[1]):
                img[r, c] = background_at(&self.sky, r, c)
        return out


def samples(const pixel_t[:, ::1] image, SkyModel model, Py_ssize_t step, bint smooth,
            Py_ssize_t k_start, Py_ssize_t k_stop, double[::1] res, double[::1] det):
    """Residual and detection-image values on the grid [::step, ::step], for noise stats:
    sampled rows ``k_start`` .. ``k_stop - 1`` (row k is image row k * step) into their
    places in ``res`` and ``det`` (len(range(0, W, step)) values a row)."""
    cdef Py_ssize_t h = image.shape[0], w = image.shape[1], k, r, d, j, c, lt, rt
    cdef Py_ssize_t n_cols = (w + step - 1) // step, i = k_start * n_cols
    cdef double[:, ::1] rows = np.empty((3, w))
    cdef double v_l, v_c, v_r
    with nogil:
        for k in range(k_start, k_stop):
            r = k * step
            for d in range(3):
                residual_row(image, &model.sky, reflect101(r + d - 1, h), rows[d])
            for j in range(n_cols):
                c = j * step
                res[i] = rows[1, c]
                if smooth:
                    lt, rt = reflect101(c - 1, w), reflect101(c + 1, w)
                    v_l = 0.25 * rows[0, lt] + 0.5 * rows[1, lt] + 0.25 * rows[2, lt]
                    v_c = 0.25 * rows[0, c] + 0.5 * rows[1, c] + 0.25 * rows[2, c]
                    v_r = 0.25 * rows[0, rt] + 0.5 * rows[1, rt] + 0.25 * rows[2, rt]
                    det[i] = 0.25 * v_l + 0.5 * v_c + 0.25 * v_r
                else:
                    det[i] = rows[1, c]
                i += 1


cdef Py_ssize_t _row_runs(const double[::1] det, double threshold,
                          long long[:, ::1] out) noexcept nogil:
    """Runs of ``det > threshold`` as (start, end) pairs in ``out``; returns their count.
    Most of a row lies below the threshold: it is tested in chunks by a vectorised count,
    and only chunks with a pixel above are walked pixel by pixel."""
    cdef Py_ssize_t w = det.shape[0], n = 0, chunk, c0, c1, c, above
    cdef bint inside = False
    for chunk in range((w + CHUNK - 1) // CHUNK):
        c0 = chunk * CHUNK
        c1 = min(c0 + CHUNK, w)
        above = 0
        for c in range(c0, c1):
            above += det[c] > threshold
        if above == 0:
            if inside:
                out[1, n] = c0 - 1
                n += 1
                inside = False
            continue
        for c in range(c0, c1):
            if det[c] > threshold:
                if not inside:
                    out[0, n] = c
                    inside = True
            elif inside:
                out[1, n] = c - 1
                n += 1
                inside = False
    if inside:
        out[1, n] = w - 1
        n += 1
    return n


def row_runs(const double[::1] det, double threshold, long long[:, ::1] out):
    """Runs of ``det > threshold`` as (start, end) pairs in ``out`` (2 x >= W/2 + 1);
    returns their count."""
    return _row_runs(det, threshold, out)


cdef void _add_run(double* acc, const pixel_t[:, ::1] image, const double[::1] res_row,
                   Py_ssize_t r, Py_ssize_t s, Py_ssize_t e, double sat_level) noexcept nogil:
    """Moments of one run (row r, columns s..e) of detected pixels into ``acc``."""
    cdef Py_ssize_t w = image.shape[1], c
    cdef double sw = 0.0, swx = 0.0, swxx = 0.0, flux = 0.0, sat = 0.0, peak = -INFINITY
    cdef double at = 0.0
    cdef double v, wgt
    for c in range(s, e + 1):
        v = res_row[c]
        wgt = max(v, 0.0)  # negative noise pixels would pull the centroid off the star
        sw += wgt
        swx += wgt * c
        swxx += wgt * c * c
        flux += v
        if <double>image[r, c] >= sat_level:
            sat = 1.0
        if v >= peak:  # ties: the last pixel in raster order
            peak, at = v, <double>(r * w + c)
    acc[SW], acc[SWX], acc[SWY], acc[FLUX] = sw, swx, sw * r, flux
    acc[SWXX], acc[SWXY], acc[SWYY] = swxx, swx * r, sw * r * r
    acc[AREA], acc[SAT], acc[PEAK], acc[PEAK_AT] = e - s + 1.0, sat, peak, at


cdef struct Runs:
    long long* where  # (row, first column, last column) each
    double* acc  # N_ACC moments each
    Py_ssize_t n, capacity


cdef bint _grow(Runs* runs, Py_ssize_t need) noexcept nogil:
    """Room for ``need`` runs; False when memory ran out."""
    cdef Py_ssize_t cap = max(2 * runs.capacity, need, 256)
    cdef long long* where
    cdef double* acc
    if need <= runs.capacity:
        return True
    where = <long long*>realloc(runs.where, 3 * cap * sizeof(long long))
    if where != NULL:
        runs.where = where
    acc = <double*>realloc(runs.acc, N_ACC * cap * sizeof(double))
    if acc != NULL:
        runs.acc = acc
    if where == NULL or acc == NULL:
        return False
    runs.capacity = cap
    return True


cdef bint _find_runs(const pixel_t[:, ::1] image, const PixelSky* sky, double threshold,
                     bint smooth, double sat_level, Py_ssize_t r_start, Py_ssize_t r_stop,
                     double[:, ::1] ring, double[::1] vbuf, double[::1] det,
                     long long[:, ::1] spans, Runs* runs) noexcept nogil:
    cdef Py_ssize_t r, i, n_cur, mid
    for r in range(r_start, r_stop):
        mid = detection_row(image, sky, r, r_start, ring, vbuf, det, smooth)
        n_cur = _row_runs(det, threshold, spans)
        if not _grow(runs, runs.n + n_cur):
            return False
        for i in range(n_cur):
            runs.where[3 * runs.n] = r
            runs.where[3 * runs.n + 1] = spans[0, i]
            runs.where[3 * runs.n + 2] = spans[1, i]
            _add_run(runs.acc + N_ACC * runs.n, image, ring[mid], r, spans[0, i], spans[1, i],
                     sat_level)
            runs.n += 1
    return True


def band_runs(const pixel_t[:, ::1] image, SkyModel model, double threshold, bint smooth,
              double sat_level, Py_ssize_t r_start, Py_ssize_t r_stop):
    """Runs of detection > ``threshold`` in rows ``r_start`` .. ``r_stop - 1``, in raster
    order: (row, first column, last column) each, and their moments (``COLUMNS`` of the
    accumulator, the peak's position a raster index)."""
    cdef Py_ssize_t w = image.shape[1]
    cdef double[:, ::1] ring = np.empty((3, w))
    cdef double[::1] vbuf = np.empty(w), det = np.empty(w)
    cdef long long[:, ::1] spans = np.empty((2, w // 2 + 1), np.int64)
    cdef Runs runs
    cdef bint ok
    runs.where, runs.acc, runs.n, runs.capacity = NULL, NULL, 0, 0
    try:
        with nogil:
            ok = _find_runs(image, &model.sky, threshold, smooth, sat_level, r_start, r_stop,
                            ring, vbuf, det, spans, &runs)
        if not ok:
            raise MemoryError("band_runs: no memory for the detected runs")
        where = np.empty((runs.n, 3), np.int64)
        acc = np.empty((runs.n, N_ACC))
        if runs.n:
            where.ravel()[:] = <long long[:runs.n * 3]>runs.where
            acc.ravel()[:] = <double[:runs.n * N_ACC]>runs.acc
        return where, acc
    finally:
        free(runs.where)
        free(runs.acc)


def peak_boxes(const pixel_t[:, ::1] image, SkyModel model, const double[:] peak_at):
    """Residual summed over the 3 x 3 box around each peak (reflected at the border)."""
    cdef Py_ssize_t h = image.shape[0], w = image.shape[1], i, pr, pc, dr, dc, r, c
    boxes = np.zeros(peak_at.shape[0])
    cdef double[::1] out = boxes
    cdef double v
    with nogil:
        for i in range(peak_at.shape[0]):
            pr = <Py_ssize_t>peak_at[i] // w
            pc = <Py_ssize_t>peak_at[i] % w
            for dr in range(-1, 2):
                r = min(max(pr + dr, 0), h - 1)  # one pixel past the border reflects onto it
                for dc in range(-1, 2):
                    c = min(max(pc + dc, 0), w - 1)
                    v = <double>image[r, c]
                    if isfinite(v):
                        out[i] += v - background_at(&model.sky, r, c)
    return boxes
