"""Small vector geometry the matchers share, compiled: on a frame's stars numpy's matmul,
clip and arccos cost more in calls than in arithmetic."""

import numpy as np

from libc.math cimport acos, fmax, fmin


def angle_table(const double[:, ::1] a, const double[:, ::1] b):
    """Angles (radians) between the rows of unit vectors ``a`` (n, 3) and ``b`` (m, 3),
    as an (n, m) array; a dot product beyond [-1, 1] by rounding is clipped."""
    out = np.empty((a.shape[0], b.shape[0]))
    cdef double[:, ::1] view = out
    cdef Py_ssize_t i, j
    cdef double dot
    for i in range(a.shape[0]):
        for j in range(b.shape[0]):
            dot = a[i, 0] * b[j, 0] + a[i, 1] * b[j, 1] + a[i, 2] * b[j, 2]
            view[i, j] = acos(fmax(-1.0, fmin(1.0, dot)))
    return out
