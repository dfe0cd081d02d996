# numpy arrays made through numpy's C API: a kernel makes several per call, and numpy's
# Python functions cost a microsecond each (np.full nearly three), more than the
# arithmetic of a frame's tens of stars.

cimport numpy as cnp

from libc.string cimport memset


cdef inline cnp.ndarray _new(Py_ssize_t n, int typenum, bint zero):
    cdef cnp.npy_intp d = n
    if zero:
        return cnp.PyArray_ZEROS(1, &d, typenum, 0)
    return cnp.PyArray_EMPTY(1, &d, typenum, 0)


cdef inline cnp.ndarray empty_f64(Py_ssize_t n):
    return _new(n, cnp.NPY_FLOAT64, False)


cdef inline cnp.ndarray empty_i64(Py_ssize_t n):
    return _new(n, cnp.NPY_INT64, False)


cdef inline cnp.ndarray zeros_f64(Py_ssize_t n):
    return _new(n, cnp.NPY_FLOAT64, True)


cdef inline cnp.ndarray zeros_i64(Py_ssize_t n):
    return _new(n, cnp.NPY_INT64, True)


cdef inline cnp.ndarray zeros_u8(Py_ssize_t n):
    return _new(n, cnp.NPY_UINT8, True)


cdef inline cnp.ndarray empty_rows(Py_ssize_t n, Py_ssize_t width):
    """An (n, width) float64 array, C order."""
    cdef cnp.npy_intp[2] d
    d[0], d[1] = n, width
    return cnp.PyArray_EMPTY(2, d, cnp.NPY_FLOAT64, 0)


cdef inline cnp.ndarray full_i64(Py_ssize_t n, long long value):
    cdef cnp.ndarray out = empty_i64(n)
    cdef long long* p = <long long*>cnp.PyArray_DATA(out)
    cdef Py_ssize_t i
    for i in range(n):
        p[i] = value
    return out


cdef inline cnp.ndarray full_f64(Py_ssize_t n, double value):
    cdef cnp.ndarray out = empty_f64(n)
    cdef double* p = <double*>cnp.PyArray_DATA(out)
    cdef Py_ssize_t i
    for i in range(n):
        p[i] = value
    return out


cdef inline cnp.ndarray ones_u8(Py_ssize_t n):
    cdef cnp.ndarray out = zeros_u8(n)
    memset(cnp.PyArray_DATA(out), 1, n)
    return out


cdef inline cnp.ndarray copy_i64(const long long[::1] values, Py_ssize_t n):
    """The first ``n`` values as a new array."""
    cdef cnp.ndarray out = empty_i64(n)
    cdef long long* p = <long long*>cnp.PyArray_DATA(out)
    cdef Py_ssize_t i
    for i in range(n):
        p[i] = values[i]
    return out


# A scratch buffer that grows: ``held`` when it holds n values, else a new array of twice
# that (a kernel's buffers settle after a few calls); never the unset buffer of a new
# scratch (no values).
cdef inline long long[::1] room_i64(long long[::1] held, Py_ssize_t n):
    if held.shape[0] < n or held.shape[0] == 0:
        return empty_i64(max(2 * n, 16))
    return held


cdef inline double[::1] room_f64(double[::1] held, Py_ssize_t n):
    if held.shape[0] < n or held.shape[0] == 0:
        return empty_f64(max(2 * n, 16))
    return held


cdef inline unsigned char[::1] room_u8(unsigned char[::1] held, Py_ssize_t n):
    if held.shape[0] < n or held.shape[0] == 0:
        return zeros_u8(max(2 * n, 16))
    return held


cdef inline double[:, ::1] room_rows(double[:, ::1] held, Py_ssize_t n):
    """As room_f64, for (n, 3) rows."""
    if held.shape[0] < n or held.shape[0] == 0:
        return empty_rows(max(2 * n, 16), 3)
    return held
