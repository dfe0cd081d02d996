"""Python's entry points to the one verification (``_verify``, ``_labelling``,
``_nearest``, ``_cone``): a hypothesis checked in one call (:class:`Verifier`), and the
steps some Python callers take on their own (projection, matching, labelling, the cone
of catalog rows, residuals, the first test of many hypotheses).

The frame's constants travel as named structures: a ``dict`` with the fields of
``Geometry``, ``CheckParams`` or ``LabelParams`` (``verification.pxd``, ``labelling.pxd``)
converts to the structure.
"""

import numpy as np

cimport numpy as cnp
from startrack._core._arrays cimport empty_rows
from startrack._core.database.cone cimport ConeTable as _ConeTable, cone_rows as _cone_rows
from startrack._core.verify.labelling cimport LabelParams, Labels, label
from startrack._core.verify.verification cimport CheckParams, Geometry, Projection, Status
from startrack._core.verify.verification cimport Frame as _Frame, Stars as _Stars, Verdict as _Verdict
from startrack._core.verify.verification cimport binomial_tail as _binomial_tail
from startrack._core.verify.verification cimport check_cone, check_fixed, fits_within, within
from startrack._core.verify.verification cimport match as _match, new_frame, project as _project
from startrack._core.verify.verification cimport residual_arcsec as _residual_arcsec
from startrack._core._wahba cimport wahba
from startrack._core.camera.optics cimport Optics

# The records Python builds and reads, under their own names.
ConeTable, Frame, Stars, Verdict = _ConeTable, _Frame, _Stars, _Verdict

BAD_INDEX, REJECTED, NOT_ACCEPTED, ACCEPTED, UNLABELLED = (
    Status.BAD_INDEX, Status.REJECTED, Status.NOT_ACCEPTED, Status.ACCEPTED, Status.UNLABELLED)

cnp.import_array()  # the C API the _arrays helpers call


def frame_through(Optics optics, const double[:, ::1] vectors, const double[::1] x,
                  const double[::1] y, const double[::1] flux):
    """The :class:`Frame` of the observed stars seen through ``optics`` (its camera read
    in C: ``Frame(..., geometry)`` takes it as a dict, converted both ways)."""
    return new_frame(vectors, x, y, flux, &optics.geometry)


cdef class Verifier:
    """One frame's verification: its observed stars (:class:`Frame`), its constants
    (``CheckParams``) and where the catalog stars come from: a cone looked up around each
    hypothesis's attitude (``table``, every star's ``mags``), or fixed ``stars`` (e.g.
    those around a tracking prediction)."""
    cdef _Frame frame
    cdef CheckParams params
    cdef _ConeTable table
    cdef const double[::1] mags
    cdef _Stars stars

    def __init__(self, _Frame frame, CheckParams params, _ConeTable table,
                 const double[::1] mags, _Stars stars=None):
        if mags.shape[0] != table.vectors.shape[0]:
            raise ValueError("Verifier: one magnitude per catalog star")
        self.frame, self.params, self.table, self.mags, self.stars = (frame, params, table,
                                                                      mags, stars)

    def check(self, const long long[::1] hyp_obs, const long long[::1] hyp_rows):
        """Verify the hypothesis that observed star ``hyp_obs[k]`` is catalog row
        ``hyp_rows[k]`` (:class:`Verdict`)."""
        if self.stars is None:
            return check_cone(self.frame, hyp_obs, hyp_rows, self.table, self.mags,
                              self.params)
        return check_fixed(self.frame, hyp_obs, hyp_rows, self.table.vectors, self.stars,
                           self.params)


def binomial_tail(long long k, long long n, double p):
    """P(X > k) for X ~ Binomial(n, p), as ``scipy.special.bdtrc`` (0 where it
    underflows)."""
    return _binomial_tail(k, n, p)


def project(const double[:, ::1] vectors, const double[:, :] matrix, Geometry geometry,
            double margin):
    """Pixel positions of catalog vectors (n, 3) at ``matrix`` (camera to sky) and
    whether each falls in the image widened by ``margin`` px: (x, y, inside)."""
    cdef Projection p = _project(vectors, matrix, geometry)
    return (np.asarray(p.x), np.asarray(p.y),
            np.asarray(within(p, geometry, margin)).view(np.bool_))


def match(_Frame frame, const double[:, ::1] vectors, const double[:, :] matrix,
          double radius):
    """The frame's stars paired with ``vectors`` projected at ``matrix``, each within
    ``radius`` px, one to one (nearest wins): (observed ascending, vector position,
    vectors in the image widened by the radius)."""
    return tuple(_match(frame, vectors, matrix, radius))


def residual_arcsec(const double[:, ::1] obs_vectors, const long long[::1] obs_index,
                    const double[:, :] matrix, const double[:, :] cat_vectors):
    """Angle (arcsec) between each observed star ``obs_vectors[obs_index[k]]`` rotated to
    the sky by ``matrix`` (camera to sky) and its catalog vector ``cat_vectors[k]``."""
    return np.asarray(_residual_arcsec(obs_vectors, obs_index, matrix, cat_vectors))


def fitting_rows(const double[:, ::1] obs_vectors, const long long[::1] hyp_obs, rows,
                 const double[:, ::1] row_vectors, double cos_radius):
    """The hypotheses (``rows``: one per hypothesis, its catalog stars for the observed
    ``hyp_obs``, as rows of ``row_vectors``) whose pairs each lie within the match radius
    at their Wahba fit (verification's first test); all when ``cos_radius`` < -1."""
    if cos_radius < -1.0:
        return rows
    cdef const long long[:, :] r = rows
    cdef Py_ssize_t m = hyp_obs.shape[0], h, k
    cdef double[:, ::1] cam = empty_rows(m, 3), sky = empty_rows(m, 3), fit = empty_rows(3, 3)
    keep = np.zeros(r.shape[0], np.bool_)
    for k in range(m):
        cam[k, :] = obs_vectors[hyp_obs[k], :]
    for h in range(r.shape[0]):
        for k in range(m):
            sky[k, :] = row_vectors[r[h, k], :]
        wahba(cam, sky, fit)
        keep[h] = fits_within(cam, sky, fit, cos_radius)
    return rows[keep]


def cone_rows(_ConeTable table, const double[:] direction, double radius):
    """Catalog rows within ``radius`` (rad) of the unit vector ``direction``, ascending
    (:class:`startrack.database._cone.ConeIndex` holds the table)."""
    return np.asarray(_cone_rows(table, direction, radius))


def label_stars(const double[::1] ox, const double[::1] oy, const double[::1] x,
                const double[::1] y, const double[::1] mag, const long long[::1] rows,
                const double[::1] flux, LabelParams params):
    """The final labelling (:func:`startrack.verify.label_stars`): the observed stars
    at (ox, oy) with fluxes ``flux`` against the catalog stars projected at (x, y), with
    magnitudes ``mag`` and catalog ``rows``. Returns (observed index ascending, catalog
    rows, withheld counts, residual scatter, brightness scatter, brightness used)."""
    return tuple(label(ox, oy, x, y, mag, rows, flux, params))
