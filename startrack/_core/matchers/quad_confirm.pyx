"""The quad search's first look at its candidates: for each, the attitude its four stars
give (Wahba) at its own focal length, and how many of the brightest other image stars
then fall within a few pixels of a catalog star (see
:func:`startrack.matchers._quad.confirmations`)."""

import numpy as np

from libc.math cimport sqrt

from startrack._core.database.cone cimport ConeTable, any_within
from startrack._core._wahba cimport wahba


cdef class ConfirmRules:
    def __init__(self, *, double radius_px, Py_ssize_t check_stars):
        self.radius_px, self.check_stars = radius_px, check_stars


cdef inline void _pinhole(double x, double y, double cx, double cy, double f,
                          double[:] out) noexcept:
    """The unit vector of pixel (x, y) through a pinhole of focal length ``f``."""
    cdef double a = (x - cx) / f, b = (y - cy) / f
    cdef double norm = sqrt(a * a + b * b + 1.0)
    out[0], out[1], out[2] = a / norm, b / norm, 1.0 / norm


cdef class Confirmer:
    def __init__(self, ConfirmRules rules, const double[::1] x, const double[::1] y,
                 double cx, double cy, ConeTable table):
        self.rules, self.x, self.y, self.cx, self.cy, self.table = rules, x, y, cx, cy, table
        self.cam, self.sky, self.r = np.empty((4, 3)), np.empty((4, 3)), np.empty((3, 3))
        self.v = np.empty(3)
        self.spans = np.empty((2 * table.band_start.shape[0], 2), np.int64)

    cdef long long count(self, const long long *obs4, const long long *cat4, double f):
        """How many of the ``check_stars`` brightest image stars outside the pattern
        (image stars ``obs4`` as catalog rows ``cat4``, focal length ``f``) lie within
        ``radius_px`` of a catalog star at the pattern's attitude; -1 if a row is beyond
        the table."""
        cdef Py_ssize_t n = min(self.rules.check_stars, self.x.shape[0]), i
        cdef const double[:, ::1] cat = self.table.vectors
        cdef double[:, ::1] r = self.r
        cdef double[::1] v = self.v
        cdef long long hits = 0
        cdef int k
        for k in range(4):
            if not 0 <= cat4[k] < cat.shape[0]:
                return -1
            _pinhole(self.x[obs4[k]], self.y[obs4[k]], self.cx, self.cy, f, self.cam[k])
            self.sky[k, 0], self.sky[k, 1], self.sky[k, 2] = (cat[cat4[k], 0], cat[cat4[k], 1],
                                                               cat[cat4[k], 2])
        wahba(self.cam, self.sky, r)
        for i in range(n):
            if i == obs4[0] or i == obs4[1] or i == obs4[2] or i == obs4[3]:
                continue
            _pinhole(self.x[i], self.y[i], self.cx, self.cy, f, v)
            if any_within(self.table, r[0, 0] * v[0] + r[0, 1] * v[1] + r[0, 2] * v[2],
                          r[1, 0] * v[0] + r[1, 1] * v[1] + r[1, 2] * v[2],
                          r[2, 0] * v[0] + r[2, 1] * v[1] + r[2, 2] * v[2],
                          self.rules.radius_px / f, self.spans):
                hits += 1
        return hits


def confirmations(Confirmer confirmer, const long long[:, ::1] obs_q,
                  const long long[:, ::1] cat_q, const double[::1] f):
    """:meth:`Confirmer.count` of each candidate ``p`` (image stars ``obs_q[p]`` as
    catalog rows ``cat_q[p]``, focal length ``f[p]``)."""
    out = np.zeros(obs_q.shape[0], np.int64)
    cdef long long[::1] count = out
    cdef Py_ssize_t p
    for p in range(obs_q.shape[0]):
        count[p] = confirmer.count(&obs_q[p, 0], &cat_q[p, 0], f[p])
    return out
