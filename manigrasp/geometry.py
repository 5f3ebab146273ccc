"""Rigid-pose helpers in pure NumPy (no MuJoCo): the one home for pose arithmetic shared across layers.

Quaternions are MuJoCo's (w, x, y, z); poses are (..., 4, 4) homogeneous matrices [m].
"""

from __future__ import annotations

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
