"""Rigid-pose helpers in pure NumPy (no MuJoCo): the one home for pose arithmetic shared across layers.

Quaternions are MuJoCo's (w, x, y, z); poses are (..., 4, 4) homogeneous matrices [m].
"""

from __future__ import annotations

import math

import numpy as np


def pose_from_pos_quat(position: np.ndarray, quat: np.ndarray) -> np.ndarray:
    """(n, 4, 4) poses from positions (n, 3) [m] and quaternions (n, 4) (w, x, y, z), NOT normalised.

    The rotation block is the standard quaternion-to-matrix formula applied as given: for
    q = s q' (q' unit) it is I + s^2 (R(q') - I), a non-rotation that a caller's rigidity check
    can report, except when R(q') = I (q = (w, 0, 0, 0)), which gives the identity for any w.
    """
    w, x, y, z = np.moveaxis(np.asarray(quat, float), -1, 0)
    out = np.zeros((len(position), 4, 4))
    out[:, :3, :3] = np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1)], -2)
    out[:, :3, 3] = position
    out[:, 3, 3] = 1.0
    return out


RIGID_TOLERANCE = 1e-5
"""The one tolerance of "is this a rigid transform / a unit quaternion" [-]: the largest entry of
|R^T R - I| of a pose's rotation block, of |last row - (0, 0, 0, 1)|, and of ||q|| - 1 for a quaternion.
Every layer (planners, grasp files, the protocol, the scene, the controllers, cameras) checks with it,
so a pose one layer accepts is never refused by the next. 1e-5 accepts rotations written with 6
decimals (a typical text grasp file) and refuses anything visibly sheared."""


def rigid_defect(pose: np.ndarray) -> str | None:
    """Why `pose` is not a finite (4, 4) rigid transform within `RIGID_TOLERANCE`, or None: a predicate
    to follow the pose's name ("grasp pose " + defect), e.g. "contains NaN or inf"."""
    pose = np.asarray(pose, dtype=float)
    if pose.shape != (4, 4):
        return f"has shape {pose.shape}, not (4, 4)"
    if not np.all(np.isfinite(pose)):
        return "contains NaN or inf"
    if np.max(np.abs(pose[3] - (0.0, 0.0, 0.0, 1.0))) > RIGID_TOLERANCE:
        return f"has last row {pose[3].tolist()}, not [0, 0, 0, 1]"
    rot = pose[:3, :3]
    off = float(np.max(np.abs(rot.T @ rot - np.eye(3))))
    if off > RIGID_TOLERANCE or np.linalg.det(rot) <= 0:
        return (f"has a rotation block that is not a rotation (|R^T R - I| up to {off:.2g}, det "
                f"{np.linalg.det(rot):.6g}; a proper rotation has det +1 and |R^T R - I| <= {RIGID_TOLERANCE:g})")
    return None


def is_rigid(pose: np.ndarray) -> bool:
    """True if `pose` is a finite (4, 4) rigid transform within `RIGID_TOLERANCE`."""
    return rigid_defect(pose) is None


def check_rigid(pose: np.ndarray, name: str = "pose") -> np.ndarray:
    """`pose` as a float (4, 4) array; raises ValueError naming `name` if it is not rigid (`rigid_defect`)."""
    defect = rigid_defect(pose)
    if defect is not None:
        raise ValueError(f"{name} {defect}")
    return np.asarray(pose, dtype=float)


def quaternion_defect(quat: np.ndarray) -> str | None:
    """Why `quat` (4,) is not a finite unit quaternion within `RIGID_TOLERANCE`, or None (a predicate, as
    `rigid_defect`'s)."""
    q = np.asarray(quat, dtype=float)
    if q.shape != (4,):
        return f"has shape {q.shape}, not (4,) (w, x, y, z)"
    if not np.all(np.isfinite(q)):
        return "contains NaN or inf"
    norm = float(np.linalg.norm(q))
    if abs(norm - 1.0) > RIGID_TOLERANCE:
        return f"is not a unit quaternion (norm {norm:.6g}; allowed 1 +- {RIGID_TOLERANCE:g})"
    return None


# ------------------------------------------------------------ rotations, poses, distances
# The conversions follow MuJoCo's own (mju_quat2Mat, mju_mat2Quat, mju_quat2Vel, as compiled in the
# pinned build) operation for operation, so a pose computed here equals the simulator's to the last bit
# and moving a computation between `sim` and this module changes no result (tests/test_geometry.py).

MIN_NORM = 1e-15
"""MuJoCo's mjMINVAL: a vector shorter than this has no direction; one this close to unit length is unit [-]."""


def quat_to_mat(quat: np.ndarray) -> np.ndarray:
    """(..., 3, 3) rotation matrices of quaternions (..., 4) (w, x, y, z), each normalised first."""
    q = np.asarray(quat, float)
    q = q / (np.linalg.norm(q) if q.ndim == 1 else np.linalg.norm(q, axis=-1, keepdims=True))
    return _unit_quat_to_mat(q)


def _unit_quat_to_mat(q: np.ndarray) -> np.ndarray:
    """(..., 3, 3) of quaternions (..., 4) taken as unit (not normalised)."""
    w, x, y, z = np.moveaxis(q, -1, 0)
    q00, q01, q02, q03 = w * w, w * x, w * y, w * z
    q11, q12, q13, q22, q23, q33 = x * x, x * y, x * z, y * y, y * z, z * z
    out = np.stack([(q00 - q22) + (q11 - q33), 2 * (q12 - q03), 2 * (q13 + q02),
                    2 * (q12 + q03), (q00 + q22) - (q11 + q33), 2 * (q23 - q01),
                    2 * (q13 - q02), 2 * (q23 + q01), (q00 - q22) + (q33 - q11)], axis=-1)
    return out.reshape(q.shape[:-1] + (3, 3))


def mat_to_quat(mat: np.ndarray) -> np.ndarray:
    """(..., 4) unit quaternions (w, x, y, z) of rotation matrices (..., 3, 3).

    The component of largest magnitude comes from the diagonal, the others from the off-diagonal
    terms (well conditioned for every rotation). q and -q are the same rotation; the sign is MuJoCo's.
    """
    m = np.asarray(mat, float).reshape(-1, 9)
    rows = np.arange(len(m))
    m0, m1, m2, m3, m4, m5, m6, m7, m8 = m.T
    case = np.select([m0 + m4 + m8 > 0, (m0 > m4) & (m0 > m8), m4 > m8], [0, 1, 2], 3)
    big = 0.5 * np.sqrt(np.stack([1 + m0 + m4 + m8, 1 + m0 - m4 - m8, 1 - m0 + m4 - m8, 1 - m0 - m4 + m8],
                                 axis=1)[rows, case])
    a, b, c = (m7 - m5, m2 - m6, m3 - m1), (m1 + m3, m2 + m6, m5 + m7), big
    options = np.stack([np.stack([c, 0.25 * a[0] / c, 0.25 * a[1] / c, 0.25 * a[2] / c], -1),
                        np.stack([0.25 * a[0] / c, c, 0.25 * b[0] / c, 0.25 * b[1] / c], -1),
                        np.stack([0.25 * a[1] / c, 0.25 * b[0] / c, c, 0.25 * b[2] / c], -1),
                        np.stack([0.25 * a[2] / c, 0.25 * b[1] / c, 0.25 * b[2] / c, c], -1)], axis=1)
    q = options[rows, case]
    norm = np.sqrt(q[:, 0] * q[:, 0] + q[:, 1] * q[:, 1] + q[:, 2] * q[:, 2] + q[:, 3] * q[:, 3])
    q = np.where((np.abs(norm - 1.0) > MIN_NORM)[:, None], q * (1.0 / norm)[:, None], q)
    return q.reshape(np.shape(mat)[:-2] + (4,))


def axis_angle_to_mat(axis: np.ndarray, angle: float) -> np.ndarray:
    """(3, 3) rotation by `angle` [rad] about the unit `axis` (3,) (right-handed)."""
    if angle == 0:
        return np.eye(3)
    half = 0.5 * angle
    q = np.concatenate([[math.cos(half)], np.asarray(axis, float) * math.sin(half)])
    return np.eye(3) if np.array_equal(q, [1.0, 0.0, 0.0, 0.0]) else _unit_quat_to_mat(q)


def rotation_log(quat: np.ndarray) -> np.ndarray:
    """(3,) rotation vector (axis x angle [rad], angle in (-pi, pi]) of a unit quaternion (4,) (w, x, y, z)."""
    w, x, y, z = (float(v) for v in quat)
    norm = math.sqrt(x * x + y * y + z * z)
    axis = np.array([1.0, 0.0, 0.0]) if norm < MIN_NORM else np.array([x, y, z]) * (1.0 / norm)
    angle = 2 * math.atan2(norm, w)
    return axis * (angle - 2 * math.pi if angle > math.pi else angle)


def rotation_error(target: np.ndarray, current: np.ndarray) -> np.ndarray:
    """(3,) rotation vector [rad], world frame, that turns `current` into `target` (both (3, 3)):
    log(target current^T), the axis-angle of the smallest rotation (a torque along it drives
    `current` toward `target`)."""
    return rotation_log(mat_to_quat(np.asarray(target, float) @ np.asarray(current, float).T))


def pose_matrix(position: np.ndarray, quat: np.ndarray | None = None) -> np.ndarray:
    """(4, 4) pose from `position` (3,) [m] and `quat` (4,) (w, x, y, z; normalised), identity rotation if None."""
    pose = np.eye(4)
    pose[:3, 3] = np.asarray(position, float)
    if quat is not None:
        pose[:3, :3] = quat_to_mat(quat)
    return pose


def pos_quat(pose: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """`(position (3,) [m], unit quaternion (4,) (w, x, y, z))` of a (4, 4) pose."""
    pose = np.asarray(pose, float)
    return pose[:3, 3].copy(), mat_to_quat(pose[:3, :3])


def invert(pose: np.ndarray) -> np.ndarray:
    """(..., 4, 4) inverses of rigid poses (..., 4, 4): [R^T, -R^T t]."""
    pose = np.asarray(pose, float)
    out = np.zeros_like(pose)
    rot_t = np.swapaxes(pose[..., :3, :3], -1, -2)
    out[..., :3, :3] = rot_t
    out[..., :3, 3] = -np.einsum("...ij,...j->...i", rot_t, pose[..., :3, 3])
    out[..., 3, 3] = 1.0
    return out


def relative_pose(frame: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """(4, 4) `pose` expressed in `frame` (both (4, 4) in one common frame): frame^-1 pose
    (e.g. the object's pose in the hand from the TCP's and the object's world poses)."""
    rot = np.asarray(frame, float)[:3, :3]
    out = np.eye(4)
    out[:3, :3] = rot.T @ np.asarray(pose, float)[:3, :3]
    out[:3, 3] = rot.T @ (np.asarray(pose, float)[:3, 3] - np.asarray(frame, float)[:3, 3])
    return out


def pose_distance(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """(translation [m], rotation angle [deg] in [0, 180]) between two (4, 4) poses."""
    diff = b[:3, 3] - a[:3, 3]
    shift = math.sqrt(float(diff @ diff))
    cos = (float(np.vdot(a[:3, :3], b[:3, :3])) - 1.0) / 2.0  # trace(A^T B) = sum(A * B)
    return shift, math.degrees(math.acos(min(1.0, max(-1.0, cos))))


def pregrasp_pose(pose: np.ndarray, offset: float) -> np.ndarray:
    """(..., 4, 4) poses moved `offset` [m] back along their own z (approach) axis: where the open hand
    starts before it approaches a grasp (a TCP pose: z = approach)."""
    out = np.array(pose, dtype=float)
    out[..., :3, 3] -= offset * out[..., :3, 2]
    return out


def perpendicular_basis(axes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors (n, 3) each, orthogonal to unit `axes` (n, 3) and to each other (a, b, axis right-handed)."""
    helper = np.where(np.abs(axes[:, [2]]) < 0.9, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])
    a = np.cross(helper, axes)
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    return a, np.cross(axes, a)
