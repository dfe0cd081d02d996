"""The one verification of a hypothesis, compiled (see ``verification.pxd`` for the interface
and how tracking calls it): the catalog projected through an attitude and the lens, the
observed stars paired with it, the first test, the binomial bound on a coincidence, the
refinement, the final labelling, the Wahba refit, the residuals and the quaternion.

A frame has tens of stars, so numpy or scipy on them is dominated by per-call overhead;
one call here does a whole hypothesis. The projection is
:meth:`startrack.camera.Camera.vector_to_pixel` then
:meth:`~startrack.camera.Camera.in_image`, operation for operation.
"""

cimport cython
import threading

import numpy as np

from libc.math cimport INFINITY, M_PI, acos, exp, fmax, fmin, lgamma, log, log1p

cimport numpy as cnp

from startrack._core._arrays cimport (copy_i64, empty_f64, empty_i64, empty_rows, room_f64,
                                      room_i64, room_rows, room_u8, zeros_f64, zeros_i64,
                                      zeros_u8)
from startrack._core.database.cone cimport ConeTable, cone_rows
from startrack._core.verify.labelling cimport LabelParams, Labels, label
from startrack._core.verify.nearest cimport (Nearest, NearestScratch, Reach, claim_nearest,
                                       nearest_matches, one_to_one, point_grid)
from startrack._core._wahba cimport matrix_to_quaternion, wahba

cnp.import_array()  # the C API the _arrays helpers call

cdef double _ARCSEC = 180.0 / M_PI * 3600.0
# cephes' MINLOG, log(2^-1022): below it scipy's bdtrc underflows to 0
cdef double _MIN_LOG = -7.08396418532264106224e2

include "verification_steps.pxi"
include "verification_match.pxi"
include "verification_refine.pxi"
include "verification_check.pxi"
