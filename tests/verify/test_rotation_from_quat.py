"""Every answer's Rotation is made by startrack.attitude.rotation_from_quat: it must be
scipy's ``Rotation.from_quat`` in all but the cost."""

import pickle

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from startrack.attitude import rotation_from_quat


def test_same_rotation_as_from_quat():
    rng = np.random.default_rng(7)
    for q in rng.normal(size=(200, 4)):
        q = q / np.linalg.norm(q) * rng.uniform(0.5, 2.0)  # from_quat normalises
        made, scipys = rotation_from_quat(q), Rotation.from_quat(q)
        assert isinstance(made, Rotation) and made.single
        assert np.array_equal(made.as_matrix(), scipys.as_matrix())
        assert np.array_equal(made.as_quat(), scipys.as_quat())
        assert np.allclose((made * scipys.inv()).magnitude(), 0.0, atol=1e-12)
        again = pickle.loads(pickle.dumps(made))
        assert np.array_equal(again.as_matrix(), scipys.as_matrix())


def test_the_quaternion_is_copied():
    q = np.array([0.0, 0.0, 0.0, 1.0])
    made = rotation_from_quat(q)
    q[:] = [1.0, 0.0, 0.0, 0.0]
    assert np.array_equal(made.as_matrix(), np.eye(3))


@pytest.mark.parametrize("q", [np.array([[0.0, 0.0, 0.0, 1.0]]),
                               np.array([0, 0, 0, 1], dtype=np.int64)])
def test_other_shapes_and_types_as_scipy_takes_them(q):
    made, scipys = rotation_from_quat(q), Rotation.from_quat(q)
    assert made.single == scipys.single
    assert np.array_equal(made.as_matrix(), scipys.as_matrix())
