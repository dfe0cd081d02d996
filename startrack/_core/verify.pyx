"""Python's entry points to the one verification (``_verify``, ``_labelling``,
``_nearest``, ``_cone``): a hypothesis checked in one call (:class:`Verifier`), and the
steps the Python callers take on their own (projection, matching, refinement, labelling,
the cone of catalog rows, residuals).

The frame's constants travel as named structures: a ``dict`` with the fields of
``Geometry``, ``CheckParams`` or ``LabelParams`` (``_verify.pxd``, ``_labelling.pxd``)
converts to the structure.
"""

import numpy as np

from startrack._core._cone cimport ConeTable, cone_rows as _cone_rows
from startrack._core._labelling cimport LabelParams, Labels, label


def label_stars(const double[::1] ox, const double[::1] oy, const double[::1] x,
                const double[::1] y, const double[::1] mag, const long long[::1] rows,
                const double[::1] flux, LabelParams params):
    """The final labelling (:func:`startrack.labelling.label_stars`): the observed stars
    at (ox, oy) with fluxes ``flux`` against the catalog stars projected at (x, y), with
    magnitudes ``mag`` and catalog ``rows``. Returns (observed index ascending, catalog
    rows, withheld counts, residual scatter, brightness scatter, brightness used)."""
    return tuple(label(ox, oy, x, y, mag, rows, flux, params))


def cone_rows(ConeTable table, const double[:] direction, double radius):
    """Catalog rows within ``radius`` (rad) of the unit vector ``direction``, ascending
    (:class:`startrack.database.cone.ConeIndex` holds the table)."""
    return _cone_rows(table, direction, radius).base
