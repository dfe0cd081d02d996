"""Attitudes: quaternion <-> RA/Dec/roll, random attitudes, and Wahba's problem.

The attitude is the rotation R with ``v_icrs = R @ v_cam``; the quaternion is
scalar-first ``[w, x, y, z]``. Roll is the angle from celestial north to the image's
up direction (camera -y), measured towards east, in [0, 360).
"""

from __future__ import annotations

import functools
import math

import numpy as np
from scipy.spatial.transform import Rotation


def _east_north(ra_deg: float, dec_deg: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    ra, dec = np.radians(ra_deg), np.radians(dec_deg)
    b = np.array([np.cos(dec) * np.cos(ra), np.cos(dec) * np.sin(ra), np.sin(dec)])
    east = np.array([-np.sin(ra), np.cos(ra), 0.0])
    north = np.array([-np.sin(dec) * np.cos(ra), -np.sin(dec) * np.sin(ra), np.cos(dec)])
    return b, east, north


def from_radec_roll(ra_deg: float, dec_deg: float, roll_deg: float) -> Rotation:
    """The attitude whose boresight points at (RA, Dec) with the given roll."""
    b, east, north = _east_north(ra_deg, dec_deg)
    r = np.radians(roll_deg)
    up = np.cos(r) * north + np.sin(r) * east
    y_cam = -up
    x_cam = np.cross(y_cam, b)
    return Rotation.from_matrix(np.column_stack([x_cam, y_cam, b]))


def to_radec_roll(rotation: Rotation) -> tuple[float, float, float]:
    """(RA, Dec, roll) in degrees of an attitude."""
    m = rotation.as_matrix()
    b = m[:, 2]
    ra = float(np.degrees(np.arctan2(b[1], b[0])) % 360.0)
    dec = float(np.degrees(np.arcsin(np.clip(b[2], -1.0, 1.0))))
    _, east, north = _east_north(ra, dec)
    up = -m[:, 1]
    roll = float(np.degrees(np.arctan2(up @ east, up @ north)) % 360.0)
    return ra, dec, roll


def to_quaternion(rotation: Rotation) -> np.ndarray:
    """Scalar-first quaternion with w >= 0."""
    q = rotation.as_quat(scalar_first=True)
    return -q if q[0] < 0 else q


def from_quaternion(q: np.ndarray) -> Rotation:
    return Rotation.from_quat(np.asarray(q, dtype=np.float64), scalar_first=True)


@functools.cache  # made on first use, not when the module is imported
def _one_rotation_maker():
    """A maker of one Rotation from a scalar-last quaternion that skips what
    ``Rotation.from_quat`` checks per call (its array namespace and shape: most of its
    ~10 us, paid by every answer); None where this scipy's Rotation is not the Python
    class this knows (scipy < 1.16: a compiled class), or where the maker does not give
    from_quat's matrix exactly."""
    probe = Rotation.from_quat(np.array([0.0, 0.0, 0.0, 1.0]))
    state = getattr(probe, "__dict__", None)
    if state is None or set(state) != {"_xp", "_single", "_backend", "_quat"} \
            or not state["_single"]:
        return None
    shared, backend = {k: v for k, v in state.items() if k != "_quat"}, state["_backend"]

    def make(quat: np.ndarray) -> Rotation:
        made = object.__new__(Rotation)
        made.__dict__.update(shared)
        # from_quat's own normalisation and copy, by the backend it would choose
        made._quat = backend.from_quat(quat.reshape(1, 4), normalize=True, copy=True,
                                       scalar_first=False)
        return made

    test = np.array([0.1, -0.2, 0.3, 0.9]) / math.sqrt(0.95)
    try:
        same = np.array_equal(make(test).as_matrix(), Rotation.from_quat(test).as_matrix())
    except Exception:  # noqa: BLE001 - any failure: scipy's own constructor serves
        return None
    return make if same else None


def rotation_from_quat(quat: np.ndarray) -> Rotation:
    """``Rotation.from_quat(quat)`` of one scalar-last quaternion ``[x, y, z, w]``
    (float64, shape (4,)), built without the per-call checks where this scipy allows."""
    make = _one_rotation_maker()
    if make is None or quat.shape != (4,) or quat.dtype != np.float64:
        return Rotation.from_quat(quat)
    return make(quat)


def random_attitudes(n: int, rng: np.random.Generator) -> Rotation:
    """``n`` attitudes uniform over SO(3)."""
    return Rotation.random(n, random_state=rng)


def wahba_matrices(cam_vectors: np.ndarray, icrs_vectors: np.ndarray) -> np.ndarray:
    """Rotation matrices R (..., 3, 3) minimising sum |icrs - R cam|^2 over the vector
    pairs (..., m, 3), for a whole batch at once (SVD, as Markley). Without scipy's
    per-call overhead, which is most of the cost for a handful of stars."""
    b = np.einsum("...ka,...kb->...ab", icrs_vectors, cam_vectors)
    u, _, vt = np.linalg.svd(b)
    d = np.sign(np.linalg.det(u) * np.linalg.det(vt))
    u = u.copy()
    u[..., :, 2] *= d[..., None]
    return u @ vt


def solve_wahba(cam_vectors: np.ndarray, icrs_vectors: np.ndarray) -> Rotation:
    """The attitude R minimising sum |icrs - R cam|^2 (see :func:`wahba_matrices`)."""
    cam = np.asarray(cam_vectors, dtype=np.float64)
    if len(cam) < 2:
        raise ValueError("Wahba's problem needs at least two vector pairs")
    return Rotation.from_matrix(wahba_matrices(cam, np.asarray(icrs_vectors, np.float64)))


def angle_between_deg(a: Rotation, b: Rotation) -> float:
    """The angle of the rotation that takes attitude a to attitude b, in degrees."""
    return float(np.degrees((a.inv() * b).magnitude()))


def boresight_error_arcsec(a: Rotation, b: Rotation) -> float:
    """Angle between the two attitudes' boresights, in arcseconds."""
    za, zb = a.apply([0.0, 0.0, 1.0]), b.apply([0.0, 0.0, 1.0])
    return float(np.degrees(np.arccos(np.clip(za @ zb, -1.0, 1.0))) * 3600.0)

__all__ = [
    "angle_between_deg", "boresight_error_arcsec", "from_quaternion", "from_radec_roll",
    "random_attitudes", "solve_wahba", "to_quaternion", "to_radec_roll", "wahba_matrices",
]
