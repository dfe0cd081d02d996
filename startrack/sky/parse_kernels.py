"""Compiled (numba) reading of fixed-width catalog records: plain decimal fields to floats,
correctly rounded, so a catalog parses in milliseconds rather than through numpy's
per-string conversion."""

from __future__ import annotations

import numpy as np
from numba import njit

# Powers of ten that are exact doubles: a mantissa below 2**53 divided by one of them is
# one correctly rounded IEEE operation, the value strtod (and numpy) give (Clinger 1990).
_POW10 = np.array([10.0**k for k in range(23)])
_MAX_MANTISSA = 2**53


@njit(cache=True)
def _is_space(c):
    return c == 32 or 9 <= c <= 13


@njit(cache=True)
def blank_rows(raw):
    """Rows of ``raw`` (records x bytes) that hold only ASCII whitespace."""
    out = np.ones(raw.shape[0], np.bool_)
    for r in range(raw.shape[0]):
        for c in range(raw.shape[1]):
            if not _is_space(raw[r, c]):
                out[r] = False
                break
    return out


@njit(cache=True)
def _parse_field(raw, r, start, stop, pow10):
    """(value, ok) of the field raw[r, start:stop]: [sign] digits [. digits], padded
    with spaces; all spaces is NaN. ok is False for anything else (exponents, tabs,
    too many digits)."""
    a, b = start, stop
    while a < b and raw[r, a] == 32:
        a += 1
    while b > a and raw[r, b - 1] == 32:
        b -= 1
    if a == b:
        return np.nan, True
    negative = raw[r, a] == 45  # '-'
    if raw[r, a] == 45 or raw[r, a] == 43:
        a += 1
    mantissa, digits, decimals, dot = 0, 0, 0, False
    for p in range(a, b):
        c = raw[r, p]
        if c == 46 and not dot:  # '.'
            dot = True
        elif 48 <= c <= 57:
            mantissa = mantissa * 10 + (c - 48)
            digits += 1
            decimals += dot
        else:
            return np.nan, False
    if digits == 0 or digits > 15 or decimals >= len(pow10) or mantissa >= _MAX_MANTISSA:
        return np.nan, False
    value = mantissa / pow10[decimals]
    return (-value if negative else value), True


@njit(cache=True)
def decimal_column(raw, start, stop):
    """Floats of byte columns [start, stop) of every record, and whether every field was
    a plain decimal (when not, the caller parses the column the general way)."""
    out = np.empty(raw.shape[0])
    for r in range(raw.shape[0]):
        out[r], ok = _parse_field(raw, r, start, stop, _POW10)
        if not ok:
            return out, False
    return out, True


def records(data: bytes, min_length: int) -> np.ndarray | None:
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
