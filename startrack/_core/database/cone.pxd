# Catalog rows within a cone of the sky (implemented in cone.pyx): declination bands of
# stars sorted by right ascension (startrack.database._cone.ConeIndex builds the table).


cdef class ConeTable:
    """Unit vectors (n, 3); ``order`` lists the rows band by band (``band_start``: each
    band's first position), by right ascension within a band (``ra_sorted``)."""
    cdef const double[:, ::1] vectors
    cdef const long long[::1] order
    cdef const double[::1] ra_sorted
    cdef const long long[::1] band_start


cdef long long[::1] cone_rows(ConeTable table, const double[:] direction, double radius)


cdef bint any_within(ConeTable table, double dx, double dy, double dz, double radius,
                     long long[:, ::1] spans) noexcept
