"""manigrasp.geometry: pose arithmetic in pure NumPy, checked against SciPy's rotations."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from manigrasp.geometry import pose_from_pos_quat


def test_unit_quaternions_give_scipys_rotations_and_the_positions() -> None:
    rng = np.random.default_rng(0)
    rotations = Rotation.random(50, random_state=rng)
    positions = rng.normal(size=(50, 3))
    poses = pose_from_pos_quat(positions, rotations.as_quat(scalar_first=True))
    np.testing.assert_allclose(poses[:, :3, :3], rotations.as_matrix(), atol=1e-12)
    np.testing.assert_allclose(poses[:, :3, 3], positions)
    np.testing.assert_array_equal(poses[:, 3], np.tile([0.0, 0.0, 0.0, 1.0], (50, 1)))


def test_a_non_unit_quaternion_is_not_normalised_into_a_rotation() -> None:
    """q = s q': I + s^2 (R(q') - I), not orthonormal (a caller's rigidity check sees it)."""
    unit = Rotation.from_euler("x", 90, degrees=True)
    pose = pose_from_pos_quat(np.zeros((1, 3)), 1.5 * unit.as_quat(scalar_first=True)[None])[0]
    np.testing.assert_allclose(pose[:3, :3], np.eye(3) + 2.25 * (unit.as_matrix() - np.eye(3)), atol=1e-12)
    assert not np.allclose(pose[:3, :3] @ pose[:3, :3].T, np.eye(3))
