"""manigrasp.geometry: pose arithmetic in pure NumPy, checked against SciPy's rotations."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from manigrasp.geometry import (
    axis_angle_to_mat,
    invert,
    mat_to_quat,
    pos_quat,
    pose_distance,
    pose_from_pos_quat,
    pose_matrix,
    pregrasp_pose,
    quat_to_mat,
    relative_pose,
    rotation_error,
    rotation_log,
)


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


def _random_poses(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    poses = np.tile(np.eye(4), (n, 1, 1))
    poses[:, :3, :3] = Rotation.random(n, random_state=rng).as_matrix()
    poses[:, :3, 3] = rng.normal(size=(n, 3))
    return poses


def test_quaternions_and_matrices_agree_with_scipy_both_ways() -> None:
    rng = np.random.default_rng(1)
    raw = rng.normal(size=(200, 4))  # not unit: quat_to_mat normalises
    rotations = Rotation.from_quat(raw, scalar_first=True)
    np.testing.assert_allclose(quat_to_mat(raw), rotations.as_matrix(), atol=1e-14)
    quats = mat_to_quat(rotations.as_matrix())
    np.testing.assert_allclose(np.linalg.norm(quats, axis=1), 1.0, atol=1e-15)
    same_rotation = np.abs(np.einsum("ij,ij->i", quats, rotations.as_quat(scalar_first=True)))
    np.testing.assert_allclose(same_rotation, 1.0, atol=1e-14)  # q or -q


@pytest.mark.parametrize("rotvec", [[np.pi, 0, 0], [0, np.pi, 0], [0, 0, np.pi], [0, 0, 0],
                                    [2.0, -2.0, 1.0], [0.0, 3.0, 0.1]])
def test_each_branch_of_the_matrix_to_quaternion_conversion(rotvec) -> None:
    """Half-turns about x, y, z (where w = 0 and each branch picks its largest component) and
    rotations whose trace is negative round-trip to their own matrix."""
    rot = Rotation.from_rotvec(rotvec).as_matrix()
    np.testing.assert_allclose(quat_to_mat(mat_to_quat(rot)), rot, atol=1e-14)


def test_conversions_match_mujocos_own_on_the_pinned_build() -> None:
    """The pure-NumPy conversions repeat MuJoCo's operations, so moving a pose between `sim` and
    `geometry` changes nothing (bit for bit on the pinned MuJoCo; 1e-15 allowed for other builds)."""
    mujoco = pytest.importorskip("mujoco")
    rng = np.random.default_rng(2)
    for q, a, b, axis, angle in zip(rng.normal(size=(300, 4)), Rotation.random(300, random_state=rng).as_matrix(),
                                    Rotation.random(300, random_state=rng).as_matrix(),
                                    Rotation.random(300, random_state=rng).as_rotvec(),
                                    rng.uniform(-4, 4, 300), strict=True):
        mat, quat, vel, spin = np.empty(9), np.empty(4), np.empty(3), np.empty(4)
        mujoco.mju_quat2Mat(mat, q / np.linalg.norm(q))
        np.testing.assert_allclose(quat_to_mat(q), mat.reshape(3, 3), rtol=0, atol=1e-15)
        mujoco.mju_mat2Quat(quat, a.ravel())
        np.testing.assert_allclose(mat_to_quat(a), quat, rtol=0, atol=1e-15)
        mujoco.mju_mat2Quat(quat, (a @ b.T).ravel())
        mujoco.mju_quat2Vel(vel, quat, 1.0)
        np.testing.assert_allclose(rotation_error(a, b), vel, rtol=0, atol=1e-15)
        unit = axis / np.linalg.norm(axis)
        mujoco.mju_axisAngle2Quat(spin, unit, angle)
        mujoco.mju_quat2Mat(mat, spin)
        np.testing.assert_allclose(axis_angle_to_mat(unit, angle), mat.reshape(3, 3), rtol=0, atol=1e-15)


def test_rotation_error_is_scipys_rotation_vector_of_target_times_current_inverse() -> None:
    rng = np.random.default_rng(3)
    for target, current in zip(Rotation.random(100, random_state=rng), Rotation.random(100, random_state=rng),
                               strict=True):
        want = (target * current.inv()).as_rotvec()
        np.testing.assert_allclose(rotation_error(target.as_matrix(), current.as_matrix()), want, atol=1e-12)
    np.testing.assert_array_equal(rotation_error(np.eye(3), np.eye(3)), np.zeros(3))


def test_axis_angle_is_scipys_rotation_vector() -> None:
    axis = np.array([1.0, 2.0, 2.0]) / 3.0
    for angle in (0.0, 0.3, -1.2, np.pi):
        np.testing.assert_allclose(axis_angle_to_mat(axis, angle), Rotation.from_rotvec(angle * axis).as_matrix(),
                                   atol=1e-15)


def test_pose_matrix_and_pos_quat_are_inverse() -> None:
    pose = _random_poses(1, 4)[0]
    pos, quat = pos_quat(pose)
    np.testing.assert_allclose(pose_matrix(pos, quat), pose, atol=1e-15)
    np.testing.assert_array_equal(pose_matrix([1.0, 2.0, 3.0])[:3, :3], np.eye(3))


def test_invert_and_relative_pose_compose_to_the_identity() -> None:
    a, b = _random_poses(2, 5)
    np.testing.assert_allclose(invert(a) @ a, np.eye(4), atol=1e-14)
    np.testing.assert_allclose(invert(_random_poses(7, 6)) @ _random_poses(7, 6), np.tile(np.eye(4), (7, 1, 1)),
                               atol=1e-14)
    in_a = relative_pose(a, b)
    np.testing.assert_allclose(in_a, np.linalg.inv(a) @ b, atol=1e-14)
    np.testing.assert_allclose(a @ in_a, b, atol=1e-14)


def test_pose_distance_of_known_offsets() -> None:
    a = _random_poses(1, 7)[0]
    b = a.copy()
    b[:3, 3] += [0.03, 0.0, 0.04]
    b[:3, :3] = b[:3, :3] @ Rotation.from_euler("z", 90, degrees=True).as_matrix()
    shift, angle = pose_distance(a, b)
    assert shift == pytest.approx(0.05) and angle == pytest.approx(90.0)
    assert pose_distance(a, a) == (0.0, 0.0)
    flip = a.copy()
    flip[:3, :3] = a[:3, :3] @ Rotation.from_euler("x", 180, degrees=True).as_matrix()
    assert pose_distance(a, flip)[1] == pytest.approx(180.0)


def test_pregrasp_pose_moves_back_along_each_approach_axis() -> None:
    poses = _random_poses(5, 8)
    back = pregrasp_pose(poses, 0.1)
    np.testing.assert_allclose(back[:, :3, 3], poses[:, :3, 3] - 0.1 * poses[:, :3, 2])
    np.testing.assert_array_equal(back[:, :3, :3], poses[:, :3, :3])
    np.testing.assert_array_equal(pregrasp_pose(poses[0], 0.0), poses[0])
    assert not np.shares_memory(back, poses)


def test_rotation_log_of_near_identity_rotations_is_mujocos_to_the_last_digit() -> None:
    """A controller holding its target sees rotations within 1e-17 of the identity: the log keeps their
    tiny angle (relative error 1e-12, no floor) and reads the identity as zero, as MuJoCo does."""
    mujoco = pytest.importorskip("mujoco")
    rng = np.random.default_rng(9)
    quats = [np.r_[1.0, rng.normal(size=3) * 10.0 ** rng.integers(-18, -6)] for _ in range(300)]
    for q in [np.array([1.0, 0, 0, 0]), np.array([1.0, 1e-17, 0, 0]), np.array([0.0, 0.9999999999999999, 0, 0]),
              *quats]:
        want = np.empty(3)
        mujoco.mju_quat2Vel(want, q, 1.0)
        np.testing.assert_allclose(rotation_log(q), want, rtol=1e-12, atol=0)
