"""What a planner sees of the settled object, per the config's `observation` switch.

- "ground_truth": the object's mesh at its true pose.
- "estimated_pose": the object's mesh (and collision parts) placed at the pose
  that the perception pipeline estimates from one noisy depth view (FPFH +
  RANSAC + ICP against the object's own model: the object's identity is
  given, its pose is not). The trial itself still runs on the true physics.
- "point_cloud": the raw segmented cloud of that view, world frame, table
  removed, normals estimated and oriented toward the camera. Its
  `object_pose` has the identity rotation and the centroid of the points as
  origin: nothing of the true pose leaks to the planner.

The view is `DEFAULT_CAMERA` aimed at the object's resting position; the
noise is drawn from a generator seeded by (`seed`, object name), so a group
sees the same frame every time it is planned.
"""

from __future__ import annotations

import math
import zlib
from dataclasses import dataclass

import numpy as np

from manigrasp.errors import ConfigError

KINDS = ("ground_truth", "estimated_pose", "point_cloud")


@dataclass(frozen=True)
class ObservationInfo:
    """How an observation was made, and how far its pose is from the truth (NaN where not applicable).

    Attributes:
        kind: the observation kind.
        rotation_error_deg, translation_error_mm, add_s_mm: errors of the estimated pose ("estimated_pose").
        fitness: fraction of observed points the placed model explains.
        n_points: points in the segmented cloud (0 for ground truth).
        backend: depth backend that ran ("" for ground truth).
    """

    kind: str
    rotation_error_deg: float = math.nan
    translation_error_mm: float = math.nan
    add_s_mm: float = math.nan
    fitness: float = math.nan
    n_points: int = 0
    backend: str = ""


_DATABASES: dict[tuple[str, str], object] = {}  # (name, visual mesh path) -> ModelDatabase, per process


def _database(asset):
    from manigrasp.perception.models import ModelDatabase

    key = (asset.name, str(asset.visual_path))
    if key not in _DATABASES:
        _DATABASES[key] = ModelDatabase.from_assets([asset])
    return _DATABASES[key]


def _camera(object_pose: np.ndarray, table_height: float):
    from manigrasp.perception.pipeline import CameraConfig

    return CameraConfig().camera(object_pose[:2, 3], table_height)


def observe_with_info(kind: str, asset, object_pose: np.ndarray, scene=None, seed: int = 0,
                      table_height: float = 0.0):
    """(`Observation`, `ObservationInfo`) of `asset` resting at `object_pose` (4, 4) in `scene`.

    Raises:
        ConfigError: unknown kind, or a perception kind without a scene.
    """
    from manigrasp.planners.base import Observation

    if kind not in KINDS:
        raise ConfigError(f"unknown observation {kind!r}; available: {', '.join(KINDS)}")
    if kind == "ground_truth":
        return Observation.from_asset(asset, object_pose, table_height), ObservationInfo(kind)
    if scene is None:
        raise ConfigError(f"observation {kind!r} needs the simulated scene to take a depth image of")
    from manigrasp.perception.pipeline import perceive

    scene.forward()
    rng = np.random.default_rng([seed, zlib.crc32(asset.name.encode())])
    geoms = np.flatnonzero(scene.model.geom_bodyid == scene.object_body)
    database = _database(asset)
    result = perceive(scene.model, scene.data, geoms, _camera(object_pose, table_height), database, rng,
                      object_name=asset.name, true_pose=object_pose, table_height=table_height)
    if kind == "point_cloud":
        pose = np.eye(4)
        pose[:3, 3] = result.cloud.points.mean(axis=0)
        observation = Observation(object_pose=pose, points=result.cloud.points, normals=result.cloud.normals,
                                  table_height=table_height)
        return observation, ObservationInfo(kind, n_points=len(result.cloud), backend=result.backend)
    errors = result.errors
    info = ObservationInfo(kind, errors.rotation_deg, errors.translation_mm, errors.add_s_mm,
                           result.estimate.fitness, len(result.cloud), result.backend)
    return Observation.from_asset(asset, result.estimate.pose, table_height), info


def observe(kind: str, asset, object_pose: np.ndarray, scene=None, seed: int = 0):
    """The `Observation` of `asset` resting at `object_pose` (4, 4); see `observe_with_info`."""
    return observe_with_info(kind, asset, object_pose, scene, seed)[0]
