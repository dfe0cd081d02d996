"""Catalog rows within a cone of the sky: declination bands of stars sorted by right
ascension (:class:`startrack.database._cone.ConeIndex`), searched over the bands and the
RA span the cone covers, then a dot-product test. Verification looks one cone up per
hypothesis, so the lookup costs microseconds."""

from cpython.mem cimport PyMem_Free, PyMem_Malloc
from libc.math cimport M_PI, asin, atan2, cos, fabs, fmax, fmin, sin
from libc.string cimport memcpy

cimport numpy as cnp
from startrack._core._arrays cimport empty_i64
from startrack._core._sort cimport first_at_least

cdef double BAND_RAD = M_PI / 180.0  # declination band height (startrack.database._cone)
# Windows are widened by this (radians) so that rounding never drops a star on an edge;
# the dot test decides.
cdef double EDGE = 1e-9

cnp.import_array()  # the C API the _arrays helpers call


cdef class ConeTable:
    def __init__(self, const double[:, ::1] vectors, const long long[::1] order,
                 const double[::1] ra_sorted, const long long[::1] band_start):
        self.vectors, self.order = vectors, order
        self.ra_sorted, self.band_start = ra_sorted, band_start


cdef Py_ssize_t _windows(ConeTable t, double dec, double ra, double radius,
                         long long* spans):
    """The (start, stop) positions of ``order`` that can hold the cone's stars, written
    into ``spans`` (a pair per window: at most two per band): per band the RA window of
    the cone (two pieces where it wraps through RA 0). Returns how many."""
    cdef Py_ssize_t n_bands = t.band_start.shape[0] - 1, b, n = 0, lo, hi, s0
    cdef Py_ssize_t b0 = max(<Py_ssize_t>((dec - radius + M_PI / 2.0) / BAND_RAD - EDGE), 0)
    cdef Py_ssize_t b1 = min(<Py_ssize_t>((dec + radius + M_PI / 2.0) / BAND_RAD + EDGE),
                             n_bands - 1)
    # The widest RA offset of any point of the cone; all of it when a pole is inside.
    cdef double half = M_PI, a, z
    if fabs(dec) + radius < M_PI / 2.0 - EDGE and radius < M_PI / 2.0:
        half = asin(fmin(1.0, sin(radius) / cos(dec))) + EDGE
    for b in range(b0, b1 + 1):
        lo, hi = t.band_start[b], t.band_start[b + 1]
        a, z = ra - half, ra + half
        if half >= M_PI:
            a, z = 0.0, 2.0 * M_PI
        elif a < 0.0:  # the window wraps through RA 0: two pieces
            spans[2 * n] = first_at_least(t.ra_sorted, lo, hi, a + 2.0 * M_PI)
            spans[2 * n + 1] = hi
            n += 1
            a = 0.0
        elif z >= 2.0 * M_PI:
            spans[2 * n] = lo
            spans[2 * n + 1] = first_at_least(t.ra_sorted, lo, hi, z - 2.0 * M_PI + EDGE)
            n += 1
            z = 2.0 * M_PI
        s0 = first_at_least(t.ra_sorted, lo, hi, a)
        spans[2 * n], spans[2 * n + 1] = s0, first_at_least(t.ra_sorted, s0, hi, z + EDGE)
        n += 1
    return n


cdef long long[::1] cone_rows(ConeTable table, const double[:] direction, double radius):
    """Rows of the table's vectors within ``radius`` of the unit vector ``direction``,
    ascending."""
    cdef double dx = direction[0], dy = direction[1], dz = direction[2]
    cdef double dec = asin(fmax(-1.0, fmin(1.0, dz))), ra = atan2(dy, dx) % (2.0 * M_PI)
    # At most two windows per band. C buffers, and numpy's C API for the one array
    # returned: a numpy array (or a slice of one) costs a microsecond through Python, and
    # its typed view a fraction of one.
    cdef Py_ssize_t n_spans = 2 * table.band_start.shape[0]
    cdef long long* held = <long long*>PyMem_Malloc(2 * n_spans * sizeof(long long))
    if held == NULL:
        raise MemoryError()
    cdef Py_ssize_t n, size = 0, w, s, row, k = 0
    cdef long long* found = NULL
    cdef double cos_radius = cos(radius)
    cdef const double[:, ::1] v = table.vectors
    try:
        n = _windows(table, dec, ra, radius, held)
        for w in range(n):
            size += held[2 * w + 1] - held[2 * w]
        found = <long long*>PyMem_Malloc(max(size, 1) * sizeof(long long))
        if found == NULL:
            raise MemoryError()
        for w in range(n):
            for s in range(held[2 * w], held[2 * w + 1]):
                row = table.order[s]
                if v[row, 0] * dx + v[row, 1] * dy + v[row, 2] * dz >= cos_radius:
                    found[k] = row
                    k += 1
        out = empty_i64(k)
        memcpy(cnp.PyArray_DATA(out), found, k * sizeof(long long))
    finally:
        PyMem_Free(held)
        PyMem_Free(found)
    cnp.PyArray_Sort(out, 0, cnp.NPY_QUICKSORT)
    return out


cdef bint any_within(ConeTable table, double dx, double dy, double dz, double radius,
                     long long[:, ::1] spans) noexcept:
    """Whether a row lies within ``radius`` of the unit vector (dx, dy, dz): the test of
    :func:`cone_rows` with no array built, for lookups a few pixels wide. ``spans``:
    scratch of two rows per declination band."""
    cdef double dec = asin(fmax(-1.0, fmin(1.0, dz))), ra = atan2(dy, dx) % (2.0 * M_PI)
    cdef Py_ssize_t n = _windows(table, dec, ra, radius, &spans[0, 0]), w, s, row
    cdef double cos_radius = cos(radius)
    cdef const double[:, ::1] v = table.vectors
    for w in range(n):
        for s in range(spans[w, 0], spans[w, 1]):
            row = table.order[s]
            if v[row, 0] * dx + v[row, 1] * dy + v[row, 2] * dz >= cos_radius:
                return True
    return False
