"""The quad search's first look at its candidates, in one call: for each, the attitude its
four stars give (Wahba) at its own focal length, and how many of the brightest other
image stars then fall within a few pixels of a catalog star (see
:func:`startrack.matchers.quad.confirmations`)."""

import numpy as np

from libc.math cimport sqrt

from startrack._core._cone cimport ConeTable, any_within
from startrack._core._wahba cimport wahba


cdef class ConfirmRules:
    """How far (pixels) a confirming star may lie from its catalog star, and how many of
    the brightest image stars are counted."""
    cdef double radius_px
    cdef Py_ssize_t check_stars

    def __init__(self, *, double radius_px, Py_ssize_t check_stars):
        self.radius_px, self.check_stars = radius_px, check_stars


cdef inline void _pinhole(double x, double y, double cx, double cy, double f,
                          double[:] out) noexcept:
    """The unit vector of pixel (x, y) through a pinhole of focal length ``f``."""
    cdef double a = (x - cx) / f, b = (y - cy) / f
    cdef double norm = sqrt(a * a + b * b + 1.0)
    out[0], out[1], out[2] = a / norm, b / norm, 1.0 / norm


cdef bint _in_range(const long long[:, ::1] cat_q, Py_ssize_t p, Py_ssize_t n_cat) noexcept:
    cdef int k
    for k in range(4):
        if not 0 <= cat_q[p, k] < n_cat:
            return False
    return True


def confirmations(ConfirmRules rules, const double[::1] x, const double[::1] y, double cx,
                  double cy, const long long[:, ::1] obs_q, const long long[:, ::1] cat_q,
                  const double[::1] f, ConeTable table):
    """For each candidate ``p`` (image stars ``obs_q[p]`` as catalog rows ``cat_q[p]`` of
    ``table``, focal length ``f[p]``): how many of the rules' ``check_stars`` brightest
    image stars outside the pattern lie within ``radius_px`` of a catalog star at the
    attitude the pattern gives (pinhole projection about (cx, cy)); -1 for a candidate
    with a row beyond the table."""
    cdef Py_ssize_t m = obs_q.shape[0], n = min(rules.check_stars, x.shape[0])
    cdef Py_ssize_t n_cat = table.vectors.shape[0], p, i
    out = np.zeros(m, np.int64)
    cdef long long[::1] count = out
    cdef double[:, ::1] cam = np.empty((4, 3)), sky = np.empty((4, 3))
    cdef double[:, ::1] r = np.empty((3, 3))
    cdef double[::1] v = np.empty(3)
    cdef long long[:, ::1] spans = np.empty((2 * table.band_start.shape[0], 2), np.int64)
    cdef int k
    cdef long long hits
    cdef bint mine
    for p in range(m):
        if not _in_range(cat_q, p, n_cat):
            count[p] = -1
            continue
        for k in range(4):
            _pinhole(x[obs_q[p, k]], y[obs_q[p, k]], cx, cy, f[p], cam[k])
            sky[k, 0] = table.vectors[cat_q[p, k], 0]
            sky[k, 1] = table.vectors[cat_q[p, k], 1]
            sky[k, 2] = table.vectors[cat_q[p, k], 2]
        wahba(cam, sky, r)
        hits = 0
        for i in range(n):
            mine = False
            for k in range(4):
                mine = mine or obs_q[p, k] == i
            if mine:
                continue
            _pinhole(x[i], y[i], cx, cy, f[p], v)
            if any_within(table, r[0, 0] * v[0] + r[0, 1] * v[1] + r[0, 2] * v[2],
                          r[1, 0] * v[0] + r[1, 1] * v[1] + r[1, 2] * v[2],
                          r[2, 0] * v[0] + r[2, 1] * v[1] + r[2, 2] * v[2],
                          rules.radius_px / f[p], spans):
                hits += 1
        count[p] = hits
    return out
