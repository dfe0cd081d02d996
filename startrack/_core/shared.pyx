"""Python entry points to the compiled core's shared routines (``_sort``, ``_wahba``,
``_stats``), for the Python callers and for the tests that hold them to numpy."""

import numpy as np

from startrack._core._sort cimport Span, first_at_least as _first_at_least
from startrack._core._sort cimport kvector_range as _kvector_range
from startrack._core._stats cimport median_inplace, ptp as _ptp
from startrack._core._wahba cimport matrix_to_quaternion as _to_quaternion
from startrack._core._wahba cimport wahba as _wahba


def first_at_least(const double[::1] values, Py_ssize_t lo, Py_ssize_t hi, double x):
    """The first position in ascending ``values[lo:hi]`` whose value is >= ``x``."""
    return _first_at_least(values, lo, hi, x)


def kvector_range(const double[::1] values, const long long[::1] kk, double m, double q,
                  double lo, double hi):
    """Positions ``(start, stop)`` of the sorted ``values`` within [lo, hi], by k-vector."""
    cdef Span span = _kvector_range(values, kk, m, q, lo, hi)
    return span.start, span.stop


def wahba(const double[:, :] cam, const double[:, :] sky):
    """The rotation matrix R minimising sum |sky_k - R cam_k|^2 over (m, 3) vector pairs."""
    r = np.empty((3, 3))
    cdef double[:, ::1] out = r
    _wahba(cam, sky, out)
    return r


def matrix_to_quaternion(const double[:, :] m):
    """Unit quaternion ``[x, y, z, w]`` (w >= 0) of a rotation matrix."""
    q = np.empty(4)
    _to_quaternion(m, q)
    return q


def median(values):
    """numpy's median of a 1-d float array (NaN for none or any NaN)."""
    cdef double[::1] scratch = np.array(values, dtype=np.float64).ravel()
    return median_inplace(scratch)


def ptp(const double[::1] values):
    """numpy's ptp of a non-empty float array (NaN if any value is NaN)."""
    return _ptp(values)
