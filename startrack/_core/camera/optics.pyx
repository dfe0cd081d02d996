"""The camera model, compiled: pixels <-> camera-frame unit vectors through a pinhole and
Brown-Conrady radial distortion (:class:`Optics`, :class:`RadialLens`).

The one implementation of the model: :class:`startrack.camera.Camera` and
:class:`startrack.camera.RadialDistortion` hold one of these each and call it, and the
compiled stages take its :c:type:`Geometry`. Every operation is numpy's, operation for
operation, so the answers are numpy's to the last bit.
"""

cimport cython
from libc.math cimport INFINITY, sqrt

import numpy as np

cimport numpy as cnp
from startrack._core._arrays cimport empty_f64, empty_rows
from startrack._core.camera.lens cimport Geometry, Lens, lens_factor, lens_is_identity, lens_of
from startrack._core.camera.lens cimport lens_undistort


cdef Lens _make_lens(double k1, double k2, double k3, double max_r2):
    cdef Lens lens
    lens.k1, lens.k2, lens.k3, lens.max_r2 = k1, k2, k3, max_r2
    lens.r_cap = sqrt(max_r2)  # inf when the model never folds back
    return lens


cdef inline double _norm(double u, double v) noexcept nogil:
    """The length of (u, v, 1): the normalised-plane point's ray."""
    return sqrt(u * u + v * v + 1.0)


cnp.import_array()  # the C API the _arrays helpers and _flat call


cdef _flat(values):
    """``values`` as a fresh contiguous float64 vector (the kernels write in place):
    ``np.array(values, dtype=np.float64).ravel()`` through numpy's C API (its Python
    calls cost more than the arithmetic of a frame's stars)."""
    cdef cnp.ndarray a = cnp.PyArray_FROM_OTF(
        values, cnp.NPY_FLOAT64,
        cnp.NPY_ARRAY_C_CONTIGUOUS | cnp.NPY_ARRAY_ENSURECOPY | cnp.NPY_ARRAY_FORCECAST)
    return a if cnp.PyArray_NDIM(a) == 1 else a.ravel()


cdef class RadialLens:
    """Brown-Conrady radial distortion on the normalised plane: the ideal point (u, v)
    is observed at (u, v) * (1 + k1 r2 + k2 r2^2 + k3 r2^3), r2 = u^2 + v^2; ``max_r2``
    is the ideal r2 up to which that is invertible (inf: everywhere)."""

    def __init__(self, double k1=0.0, double k2=0.0, double k3=0.0,
                 double max_r2=INFINITY):
        self.lens = _make_lens(k1, k2, k3, max_r2)

    def __reduce__(self):
        return RadialLens, (self.lens.k1, self.lens.k2, self.lens.k3, self.lens.max_r2)

    def distort(self, u, v):
        """Observed normalised coordinates of ideal ones (arrays of any one shape)."""
        u, v = np.asarray(u, dtype=np.float64), np.asarray(v, dtype=np.float64)
        out_u, out_v = _flat(u), _flat(v)
        cdef double[::1] a = out_u, b = out_v
        cdef Py_ssize_t i
        cdef double s
        for i in range(a.shape[0]):
            s = lens_factor(&self.lens, a[i] * a[i] + b[i] * b[i])
            a[i] = a[i] * s
            b[i] = b[i] * s
        return out_u.reshape(u.shape), out_v.reshape(v.shape)

    def undistort(self, ud, vd):
        """Ideal normalised coordinates of observed ones (Newton on the radius)."""
        ud, vd = np.asarray(ud, dtype=np.float64), np.asarray(vd, dtype=np.float64)
        if lens_is_identity(&self.lens):
            return ud, vd
        out_u, out_v = _flat(ud), _flat(vd)
        cdef double[::1] a = out_u, b = out_v
        if a.shape[0] and lens_undistort(&self.lens, &a[0], &b[0], a.shape[0], 1) < 0:
            raise MemoryError("undistort: no memory for the lens inversion")
        return out_u.reshape(ud.shape), out_v.reshape(vd.shape)


cdef class Optics:
    """A camera's pinhole (focal length ``f`` px, principal point ``cx``, ``cy``, image
    ``width`` x ``height`` px) and its :class:`RadialLens` (identity: none). Pixel (x, y)
    = (column, row); camera +z is the boresight."""

    def __init__(self, double f, double cx, double cy, double width, double height,
                 RadialLens lens=None):
        self.lens = lens if lens is not None else RadialLens()
        self._lens = self.lens.lens
        self.geometry.f_px, self.geometry.cx, self.geometry.cy = f, cx, cy
        self.geometry.width, self.geometry.height = width, height
        self.geometry.k1, self.geometry.k2, self.geometry.k3 = (
            self._lens.k1, self._lens.k2, self._lens.k3)
        self.geometry.max_r2 = self._lens.max_r2

    def __reduce__(self):
        g = self.geometry
        return Optics, (g.f_px, g.cx, g.cy, g.width, g.height, self.lens)

    @cython.cdivision(True)
    def ideal_pixels(self, x, y):
        """Where observed pixels would be without distortion (the pinhole image)."""
        x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
        if lens_is_identity(&self._lens):
            return x, y
        u, v = self._normalised(x, y)
        cdef double[::1] a = u, b = v
        cdef Py_ssize_t i
        cdef Geometry g = self.geometry
        for i in range(a.shape[0]):
            a[i] = g.cx + g.f_px * a[i]
            b[i] = g.cy + g.f_px * b[i]
        return u.reshape(x.shape), v.reshape(y.shape)

    def pixel_to_vector(self, x, y):
        """Camera-frame unit vectors (shape of ``x`` + (3,)) of pixel coordinates."""
        x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
        u, v = self._normalised(x, y)
        out = _unit_rows(u, v)
        return out if x.ndim == 1 else out.reshape(x.shape + (3,))

    def corner_cosines(self):
        """The cosine of the angle from the boresight to each image corner (the corner
        pixels' centres: top-left, top-right, bottom-left, bottom-right): the z of
        :meth:`pixel_to_vector` there, in one call (a camera's cone radius)."""
        return corner_cosines(&self.geometry)

    @cython.cdivision(True)
    def vector_to_pixel(self, vectors):
        """Pixel (x, y) of camera-frame vectors (..., 3), and a mask of those in front
        (z > 1e-12) and, with a lens, inside its fold radius (beyond it a far-off star
        would land back inside the image)."""
        v = np.asarray(vectors, dtype=np.float64)
        cdef const double[:, :] vec = v.reshape(-1, 3)
        cdef Py_ssize_t i, n = vec.shape[0]
        px, py, ok = np.empty(n), np.empty(n), np.empty(n, dtype=bool)
        cdef double[::1] ox = px, oy = py
        cdef unsigned char[::1] front = ok.view(np.uint8)
        cdef Geometry g = self.geometry
        cdef bint lens = not lens_is_identity(&self._lens)
        cdef double z, u, w, r2, s
        for i in range(n):
            z = vec[i, 2]
            front[i] = z > 1e-12
            if not front[i]:
                z = 1.0
            u, w = vec[i, 0] / z, vec[i, 1] / z
            if lens:
                r2 = u * u + w * w
                front[i] = front[i] and r2 < g.max_r2
                s = lens_factor(&self._lens, r2)
                u, w = u * s, w * s
            ox[i], oy[i] = g.cx + g.f_px * u, g.cy + g.f_px * w
        shape = v.shape[:v.ndim - 1]
        return px.reshape(shape), py.reshape(shape), ok.reshape(shape)

    @cython.cdivision(True)
    cdef tuple _normalised(self, x, y):
        """The ideal normalised coordinates (fresh vectors) of pixels ``x``, ``y``."""
        u, v = _flat(x), _flat(y)
        self._normalise(u, v)
        return u, v

    cdef void _normalise(self, double[::1] a, double[::1] b) except *:
        """Pixels ``a``, ``b`` made their ideal normalised coordinates, in place."""
        _normalise(&self.geometry, a, b)


@cython.cdivision(True)
cdef void _normalise(const Geometry* g, double[::1] a, double[::1] b) except *:
    """Pixels ``a``, ``b`` made their ideal normalised coordinates through ``g`` (its
    pinhole, then its lens inverted), in place."""
    cdef Py_ssize_t i
    for i in range(a.shape[0]):
        a[i] = (a[i] - g.cx) / g.f_px
        b[i] = (b[i] - g.cy) / g.f_px
    cdef Lens lens = lens_of(g)
    if a.shape[0] and not lens_is_identity(&lens) \
            and lens_undistort(&lens, &a[0], &b[0], a.shape[0], 1) < 0:
        raise MemoryError("pixel_to_vector: no memory for the lens inversion")


@cython.cdivision(True)
cdef object _unit_rows(const double[::1] a, const double[::1] b):
    """The unit vectors (n, 3) of the rays through normalised-plane points ``a``, ``b``."""
    out = empty_rows(a.shape[0], 3)
    cdef double[:, ::1] vec = out
    cdef double norm
    cdef Py_ssize_t i
    for i in range(a.shape[0]):
        norm = _norm(a[i], b[i])
        vec[i, 0], vec[i, 1], vec[i, 2] = a[i] / norm, b[i] / norm, 1.0 / norm
    return out


cdef object unit_vectors(const Geometry* g, const double[::1] x, const double[::1] y):
    """Camera-frame unit vectors (n, 3, a fresh array) of pixels ``x``, ``y`` through
    camera ``g``: :meth:`Optics.pixel_to_vector` for compiled callers."""
    u, v = empty_f64(x.shape[0]), empty_f64(y.shape[0])
    cdef double[::1] a = u, b = v
    a[:] = x
    b[:] = y
    _normalise(g, a, b)
    return _unit_rows(a, b)


@cython.cdivision(True)
cdef object corner_cosines(const Geometry* g):
    """:meth:`Optics.corner_cosines` of camera ``g``, for compiled callers."""
    u, v = empty_f64(4), empty_f64(4)
    cdef double[::1] a = u, b = v
    a[0], a[1], a[2], a[3] = 0.0, g.width - 1.0, 0.0, g.width - 1.0
    b[0], b[1], b[2] = 0.0, 0.0, g.height - 1.0
    b[3] = b[2]
    _normalise(g, a, b)
    cdef Py_ssize_t i
    for i in range(4):
        a[i] = 1.0 / _norm(a[i], b[i])
    return u
