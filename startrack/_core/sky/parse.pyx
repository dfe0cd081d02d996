"""Fixed-width catalog records read fast: plain decimal fields to floats, correctly
rounded, so a catalog parses in milliseconds rather than through numpy's per-string
conversion."""

import numpy as np

from libc.math cimport NAN
from libc.stdint cimport uint8_t

# Powers of ten that are exact doubles: a mantissa below 2**53 divided by one of them is
# one correctly rounded IEEE operation, the value strtod (and numpy) give (Clinger 1990).
cdef double[23] _POW10
for _k in range(23):
    _POW10[_k] = 10.0 ** _k
cdef unsigned long long _MAX_MANTISSA = 2 ** 53


cdef inline bint _is_space(uint8_t c) noexcept nogil:
    return c == 32 or 9 <= c <= 13


def blank_rows(const uint8_t[:, :] raw):
    """Rows of ``raw`` (records x bytes) that hold only ASCII whitespace."""
    out = np.ones(raw.shape[0], np.bool_)
    cdef uint8_t[::1] blank = out.view(np.uint8)
    cdef Py_ssize_t r, c
    for r in range(raw.shape[0]):
        for c in range(raw.shape[1]):
            if not _is_space(raw[r, c]):
                blank[r] = False
                break
    return out


cdef bint _parse_field(const uint8_t[:, :] raw, Py_ssize_t r, Py_ssize_t a, Py_ssize_t b,
                       double* value) noexcept nogil:
    """The field raw[r, a:b] into ``value``: [sign] digits [. digits], padded with spaces;
    all spaces is NaN. False for anything else (exponents, tabs, too many digits)."""
    cdef bint negative, dot = False
    cdef unsigned long long mantissa = 0
    cdef Py_ssize_t p, digits = 0, decimals = 0
    cdef uint8_t c
    value[0] = NAN
    while a < b and raw[r, a] == 32:
        a += 1
    while b > a and raw[r, b - 1] == 32:
        b -= 1
    if a == b:
        return True
    negative = raw[r, a] == 45  # '-'
    if raw[r, a] == 45 or raw[r, a] == 43:
        a += 1
    for p in range(a, b):
        c = raw[r, p]
        if c == 46 and not dot:  # '.'
            dot = True
        elif 48 <= c <= 57:
            if digits > 15:  # rejected below whatever follows; no overflow meanwhile
                return False
            mantissa = mantissa * 10 + (c - 48)
            digits += 1
            decimals += dot
        else:
            return False
    if digits == 0 or digits > 15 or decimals >= 23 or mantissa >= _MAX_MANTISSA:
        return False
    value[0] = -(mantissa / _POW10[decimals]) if negative else mantissa / _POW10[decimals]
    return True


def decimal_column(const uint8_t[:, :] raw, Py_ssize_t start, Py_ssize_t stop):
    """Floats of byte columns [start, stop) of every record, and whether every field was
    a plain decimal (when not, the caller parses the column the general way)."""
    values = np.empty(raw.shape[0])
    cdef double[::1] out = values
    cdef Py_ssize_t r
    cdef bint ok = True
    with nogil:
        for r in range(raw.shape[0]):
            if not _parse_field(raw, r, start, stop, &out[r]):
                ok = False
                break
    return values, ok


def records(data: bytes, min_length: int):
    """``data`` as a (records x line length) byte array, without splitting it into
    lines, when every line has the first one's length (at least ``min_length``); else
    None."""
    if data and not data.endswith(b"\n"):
        data += b"\n"
    length = data.find(b"\n")
    if length < min_length or len(data) % (length + 1):
        return None
    raw = np.frombuffer(data, np.uint8).reshape(-1, length + 1)
    if not np.all(raw[:, length] == 10):
        return None
    return raw[:, :length]
