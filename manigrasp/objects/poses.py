"""Quasi-static stable resting poses of a rigid object on a plane (pure geometry, no mujoco).

An object dropped on a table comes to rest on a face of its convex hull whose
projection contains the centre of mass. `stable_poses` ranks those faces by
their quasi-static probability (trimesh's estimate: the solid angle of the
hull face's basin of attraction seen from the centre of mass,
`trimesh.poses.compute_stable_poses`), so a scan's results no longer depend on
the orientation its file happened to be saved in.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh

from manigrasp.errors import MeshError


@dataclass(frozen=True)
class RestPose:
    """One stable pose: rotation (3, 3) of the object frame in the world (z up), the height [m]
    of the object frame's origin above the plane when resting, and its probability [-]."""

    rotation: np.ndarray
    height: float
    probability: float

    def matrix(self, xy: tuple[float, float] = (0.0, 0.0)) -> np.ndarray:
        """(4, 4) pose of the object resting at `xy` [m] on the plane z = 0."""
        pose = np.eye(4)
        pose[:3, :3] = self.rotation
        pose[:3, 3] = [xy[0], xy[1], self.height]
        return pose


def stable_poses(points: np.ndarray, com: np.ndarray | None = None) -> list[RestPose]:
    """Stable poses of the rigid body whose surface points are `points` (n, 3) [m] (object frame),
    centre of mass `com` (3,) (default the origin), most probable first (ties in a fixed order, whatever the order of
    the points). Deterministic.

    Raises:
        MeshError: fewer than 4 points not all in one plane.
    """
    points = np.asarray(points, float)
    if points.ndim != 2 or points.shape[1] != 3 or len(points) < 4:
        raise MeshError(f"stable poses need (n >= 4, 3) points, got shape {points.shape}")
    spread = np.linalg.svd(points - points.mean(axis=0), compute_uv=False)
    if spread[-1] <= 1e-9 * max(spread[0], 1e-300):
        raise MeshError("stable poses: the points have no 3-D convex hull (they lie in a plane or a line)")
    hull = trimesh.PointCloud(points).convex_hull
    com = np.zeros(3) if com is None else np.asarray(com, float)
    transforms, probs = trimesh.poses.compute_stable_poses(hull, center_mass=com, sigma=0.0, n_samples=1)
    out = []
    for transform, prob in zip(transforms, probs, strict=True):
        rotation = np.asarray(transform[:3, :3], float)
        height = -float((points @ rotation.T)[:, 2].min())
        out.append(RestPose(rotation=rotation, height=height, probability=float(prob)))
    return _ranked(out)


def _ranked(poses: list[RestPose], tie: float = 1e-9) -> list[RestPose]:
    """Most probable first; probabilities within `tie` of the previous one's are equal (a box's opposite faces:
    equal but for float noise, which the order of the points decided) and go by the object frame's up direction,
    largest component first."""
    poses = sorted(poses, key=lambda pose: -pose.probability)
    groups: list[list[RestPose]] = []
    for pose in poses:
        if groups and groups[-1][-1].probability - pose.probability <= tie:
            groups[-1].append(pose)
        else:
            groups.append([pose])
    return [pose for group in groups for pose in sorted(group, key=_up_first)]


def _up_first(pose: RestPose) -> tuple[float, ...]:
    """Sort key: the object frame's up direction, largest component first (+ 0.0: no negative zero)."""
    return tuple(-(np.round(pose.rotation[2], 6) + 0.0))
