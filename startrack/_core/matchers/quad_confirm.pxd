# The quad search's confirmation count (implemented in quad_confirm.pyx), cimported by the
# window search (quad.pyx) to look at each candidate as it is found.

from startrack._core.database.cone cimport ConeTable


cdef class ConfirmRules:
    """How far (pixels) a confirming star may lie from its catalog star, and how many of
    the brightest image stars are counted."""
    cdef double radius_px
    cdef Py_ssize_t check_stars


cdef class Confirmer:
    """One frame's image stars (pixels, principal point) and the catalog cone index they
    are confirmed against, with the scratch one count needs."""
    cdef ConfirmRules rules
    cdef const double[::1] x
    cdef const double[::1] y
    cdef double cx, cy
    cdef ConeTable table
    cdef double[:, ::1] cam
    cdef double[:, ::1] sky
    cdef double[:, ::1] r
    cdef double[::1] v
    cdef long long[:, ::1] spans

    cdef long long count(self, const long long *obs4, const long long *cat4, double f)
