"""Non-maximum suppression of grasp poses: keep the top candidates diverse.

Two poses are duplicates when their TCP positions are closer than `distance`
[m] AND their orientations differ by less than `angle` [rad]. For a
two-jaw hand, a pose and the same pose turned 180 degrees about its approach
axis (fingers swapped) are the same grasp (`symmetric=True`).
"""

from __future__ import annotations

import numpy as np

DEFAULT_DISTANCE = 0.03  # [m]
DEFAULT_ANGLE = np.radians(30.0)  # [rad]


def rotation_angles(rot: np.ndarray, others: np.ndarray, symmetric: bool = False) -> np.ndarray:
    """Angles [rad] between rotation `rot` (3, 3) and each of `others` (n, 3, 3).

    With `symmetric`, the smaller of the angle to R and to R turned by pi about its z axis.
    """
    m = np.einsum("ji,njk->nik", rot, others)  # rot.T @ other
    cos = (np.trace(m, axis1=1, axis2=2) - 1.0) / 2.0
    if symmetric:
        cos_flip = (-m[:, 0, 0] - m[:, 1, 1] + m[:, 2, 2] - 1.0) / 2.0
        cos = np.maximum(cos, cos_flip)
    return np.arccos(np.clip(cos, -1.0, 1.0))


def pairwise_close(poses: np.ndarray, positions: np.ndarray, rotations: np.ndarray, distance: float,
                   angle: float, symmetric: bool) -> np.ndarray:
    """(k, m) True where pose i (k, 4, 4) is within `distance` and `angle` of pose j (positions (m, 3),
    rotations (m, 3, 3))."""
    near = np.linalg.norm(poses[:, None, :3, 3] - positions[None], axis=2) < distance
    # (R_i.T @ R_j)[b, b] is column b of R_i dotted with column b of R_j.
    diag = [poses[:, :3, b] @ rotations[:, :, b].T for b in range(3)]  # 3 x (k, m)
    cos = (diag[0] + diag[1] + diag[2] - 1.0) / 2.0
    if symmetric:
        cos = np.maximum(cos, (-diag[0] - diag[1] + diag[2] - 1.0) / 2.0)
    return near & (cos > np.cos(angle))


class Suppressor:
    """Greedy NMS over candidates offered best first: `offer` keeps a pose unless it duplicates a kept one.

    Args:
        distance: position threshold [m].
        angle: orientation threshold [rad].
        symmetric: treat a 180-degree turn about the approach axis as the same pose.
        capacity: the most poses that will be kept.
    """

    def __init__(self, distance: float = DEFAULT_DISTANCE, angle: float = DEFAULT_ANGLE,
                 symmetric: bool = False, capacity: int = 1024) -> None:
        self.distance, self.angle, self.symmetric = float(distance), float(angle), symmetric
        self._pos = np.zeros((capacity, 3))
        self._rot = np.zeros((capacity, 3, 3))
        self.count = 0

    def is_duplicate(self, pose: np.ndarray) -> bool:
        """Whether `pose` (4, 4) is within both thresholds of a kept pose."""
        if self.count == 0:
            return False
        near = np.linalg.norm(self._pos[:self.count] - pose[:3, 3], axis=1) < self.distance
        if not near.any():
            return False
        angles = rotation_angles(pose[:3, :3], self._rot[:self.count][near], self.symmetric)
        return bool(np.any(angles < self.angle))

    def duplicates(self, poses: np.ndarray) -> np.ndarray:
        """(k,) whether each of `poses` (k, 4, 4) is within both thresholds of a kept pose (vectorised)."""
        if self.count == 0 or len(poses) == 0:
            return np.zeros(len(poses), bool)
        return pairwise_close(poses, self._pos[:self.count], self._rot[:self.count], self.distance,
                              self.angle, self.symmetric).any(axis=1)

    def keep(self, pose: np.ndarray) -> None:
        """Add `pose` (4, 4) to the kept set."""
        if self.count == len(self._pos):
            self._pos = np.concatenate([self._pos, np.zeros_like(self._pos)])
            self._rot = np.concatenate([self._rot, np.zeros_like(self._rot)])
        self._pos[self.count], self._rot[self.count] = pose[:3, 3], pose[:3, :3]
        self.count += 1


def suppress(poses: np.ndarray, distance: float = DEFAULT_DISTANCE, angle: float = DEFAULT_ANGLE,
             symmetric: bool = False) -> np.ndarray:
    """Indices of the poses (n, 4, 4), given best first, that survive greedy NMS (in order)."""
    nms = Suppressor(distance, angle, symmetric, capacity=max(1, len(poses)))
    kept = []
    for i, pose in enumerate(poses):
        if not nms.is_duplicate(pose):
            nms.keep(pose)
            kept.append(i)
    return np.array(kept, dtype=int)
