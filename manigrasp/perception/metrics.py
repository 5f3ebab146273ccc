"""Pose errors between an estimated and a true object pose (pure NumPy).

Poses are (4, 4) object-to-world transforms [m]; `points` are (n, 3) model
points in the object frame [m] (e.g. samples of its surface).

- ADD (Hinterstoisser et al. 2012): mean distance between each model point
  under the true pose and the same point under the estimated pose.
- ADD-S: mean distance from each point under the true pose to the closest
  point under the estimated pose; an object with a symmetry that maps it
  onto itself scores 0 for every pose of that symmetry.
- Rotation error: angle of R_true^T R_est [deg]. Translation error: distance
  between the two origins (centres of mass) [mm].

A pose is good (`pose_good`) when its translation error is below 1 cm and,
for an object without a symmetry, its rotation error below 5 deg; an object
with a symmetry is judged by ADD-S < 5 mm instead of the rotation, since each
pose of its symmetry is as good as the truth (Hinterstoisser et al. 2012 judge
symmetric objects by ADD-S for the same reason).
"""

from __future__ import annotations

import numpy as np

from manigrasp.geometry import pose_distance

_CHUNK = 2048  # points per block of the brute-force nearest-neighbour search

ADD_S_THRESHOLD_MM = 5.0  # ADD-S below which the pose of an object with a symmetry is good
ROTATION_THRESHOLD_DEG = 5.0  # rotation error below which the pose of an object without one is good
TRANSLATION_THRESHOLD_MM = 10.0  # translation error below which a pose can be good


def _transform(pose: np.ndarray, points: np.ndarray) -> np.ndarray:
    pose = np.asarray(pose, float)
    return np.asarray(points, float) @ pose[:3, :3].T + pose[:3, 3]


def add(points: np.ndarray, true_pose: np.ndarray, est_pose: np.ndarray) -> float:
    """ADD [m]: mean |T_true p - T_est p| over `points` (n, 3) in the object frame."""
    return float(np.linalg.norm(_transform(true_pose, points) - _transform(est_pose, points), axis=1).mean())


def nearest_distances(query: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """(n,) distance [m] from each `query` point (n, 3) to its nearest `reference` point (m, 3).

    Brute force in blocks (n * m distances): meant for a few thousand points.
    """
    query, reference = np.asarray(query, float), np.asarray(reference, float)
    ref_sq = np.einsum("ij,ij->i", reference, reference)
    out = np.empty(len(query))
    for start in range(0, len(query), _CHUNK):
        q = query[start:start + _CHUNK]
        sq = np.einsum("ij,ij->i", q, q)[:, None] - 2.0 * q @ reference.T + ref_sq[None, :]
        out[start:start + _CHUNK] = np.sqrt(np.maximum(sq.min(axis=1), 0.0))
    return out


def add_s(points: np.ndarray, true_pose: np.ndarray, est_pose: np.ndarray) -> float:
    """ADD-S [m]: mean over `points` under the true pose of the distance to the nearest point under the estimate."""
    return float(nearest_distances(_transform(true_pose, points), _transform(est_pose, points)).mean())


def rotation_error_deg(true_pose: np.ndarray, est_pose: np.ndarray) -> float:
    """Angle [deg] of the rotation between the two poses' orientations, in [0, 180] (`geometry.pose_distance`)."""
    return pose_distance(np.asarray(true_pose, float), np.asarray(est_pose, float))[1]


def translation_error_mm(true_pose: np.ndarray, est_pose: np.ndarray) -> float:
    """Distance [mm] between the two poses' origins (`geometry.pose_distance`)."""
    return 1000.0 * pose_distance(np.asarray(true_pose, float), np.asarray(est_pose, float))[0]


def pose_good(rotation_deg: float, translation_mm: float, add_s_mm: float, symmetric: bool) -> bool:
    """Whether an estimated pose is good (module docstring): translation < 1 cm and rotation < 5 deg, or for an
    object with a symmetry ADD-S < 5 mm instead of the rotation. NaN errors are not good."""
    if not translation_mm < TRANSLATION_THRESHOLD_MM:
        return False
    return bool(add_s_mm < ADD_S_THRESHOLD_MM) if symmetric else bool(rotation_deg < ROTATION_THRESHOLD_DEG)
