# The compiled camera's classes, for the stages that take a camera (cimport Optics and
# read its ``geometry``).

from startrack._core.camera.lens cimport Geometry, Lens


cdef class RadialLens:
    cdef readonly Lens lens


cdef class Optics:
    cdef readonly Geometry geometry
    cdef readonly RadialLens lens
    cdef Lens _lens
    cdef tuple _normalised(self, x, y)
    cdef void _normalise(self, double[::1] a, double[::1] b) except *


# Optics.pixel_to_vector and Optics.corner_cosines of a camera's geometry, for the
# compiled stages that change the focal length without making an Optics
cdef object unit_vectors(const Geometry* g, const double[::1] x, const double[::1] y)
cdef object corner_cosines(const Geometry* g)
