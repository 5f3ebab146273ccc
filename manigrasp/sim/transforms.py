"""Small pose helpers used by `sim` and `control` (MuJoCo quaternions: w, x, y, z).

A pose is a 4x4 homogeneous matrix `(4, 4) float` (rotation [-], translation
[m]) unless a function says `(pos, quat)`.
"""

from __future__ import annotations

import mujoco
import numpy as np

from manigrasp.geometry import check_rigid


def pose_matrix(pos: np.ndarray, quat: np.ndarray | None = None) -> np.ndarray:
    """(4, 4) pose from `pos` (3,) [m] and unit `quat` (4,) (w, x, y, z), identity if None."""
    pose = np.eye(4)
    pose[:3, 3] = np.asarray(pos, float)
    if quat is not None:
        pose[:3, :3] = quat_to_mat(quat)
    return pose


def quat_to_mat(quat: np.ndarray) -> np.ndarray:
    """(3, 3) rotation matrix of a quaternion (4,) (w, x, y, z); it is normalised first."""
    q = np.asarray(quat, float)
    q = q / np.linalg.norm(q)
    mat = np.empty(9)
    mujoco.mju_quat2Mat(mat, q)
    return mat.reshape(3, 3)


def mat_to_quat(mat: np.ndarray) -> np.ndarray:
    """Unit quaternion (4,) (w, x, y, z) of a rotation matrix (3, 3)."""
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(mat, float).ravel())
    return quat


def pos_quat(pose: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """`(pos (3,), quat (4,))` of a (4, 4) pose."""
    pose = check_pose(pose)
    return pose[:3, 3].copy(), mat_to_quat(pose[:3, :3])


def check_pose(pose: np.ndarray, name: str = "pose") -> np.ndarray:
    """`pose` as a float (4, 4) array; raises ValueError if it is not a finite rigid transform
    (`manigrasp.geometry.check_rigid`, the one tolerance every layer uses)."""
    return check_rigid(pose, name)


def rotation_error(target: np.ndarray, current: np.ndarray) -> np.ndarray:
    """Rotation vector (3,) [rad], world frame, that turns `current` into `target` (both (3, 3)).

    It is log(target @ current.T): the axis-angle of the smallest rotation,
    so a proportional torque along it drives `current` toward `target`.
    """
    quat = mat_to_quat(target @ current.T)
    vel = np.empty(3)
    mujoco.mju_quat2Vel(vel, quat, 1.0)
    return vel
