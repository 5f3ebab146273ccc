"""The points an observation carries: samples of the object's surface, or a simulated depth cloud.

- "mesh": `n` points drawn uniformly (by area) on the object's visual mesh, with the
  faces' outward normals: ground-truth geometry, as the benchmark's "ground_truth"
  observation gives a planner.
- "depth": the benchmark's "point_cloud" observation (`manigrasp.bench.observe`: the
  default camera setup, noisy depth, table removed, normals oriented toward the camera),
  resampled to a fixed `n` points so the observation keeps one shape: drawn without
  replacement when the view holds at least `n` points, with replacement otherwise.
  Needs the `perception` extra (open3d).

Points and normals are (n, 3) in the world [m]; every draw comes from the given generator.
"""

from __future__ import annotations

import importlib.util

import numpy as np
import trimesh

from manigrasp.errors import ConfigError

POINT_SOURCES = ("mesh", "depth", "none")


def check_source(source: str, n_points: int) -> None:
    """Refuse an unknown point source, a bad count, or "depth" without the perception extra (`ConfigError`)."""
    if source not in POINT_SOURCES:
        raise ConfigError(f"unknown points {source!r}; available: {', '.join(POINT_SOURCES)}")
    if source != "none" and not (isinstance(n_points, int | np.integer) and n_points > 0):
        raise ConfigError(f"n_points must be a positive integer with points={source!r}, got {n_points!r}")
    if source == "depth" and importlib.util.find_spec("open3d") is None:
        raise ConfigError("points='depth' needs the perception extra: in the manigrasp clone run "
                          "`make setup EXTRAS=dev,perception` (or "
                          "`.venv/bin/pip install -c constraints.txt -e '.[perception]'`)")


def mesh_points(mesh: trimesh.Trimesh, object_pose: np.ndarray, n: int,
                rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """`n` area-uniform surface points of `mesh` (object frame) and their face normals, moved to `object_pose`."""
    points, faces = trimesh.sample.sample_surface(mesh, n, seed=rng)
    rotation, origin = object_pose[:3, :3], object_pose[:3, 3]
    return points @ rotation.T + origin, mesh.face_normals[faces] @ rotation.T


def resample(points: np.ndarray, normals: np.ndarray, n: int,
             rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """`n` rows of a cloud: without replacement if it has at least `n`, else with replacement."""
    index = rng.choice(len(points), size=n, replace=len(points) < n)
    return np.asarray(points, float)[index], np.asarray(normals, float)[index]


def depth_points(asset, scene, object_pose: np.ndarray, n: int, seed: int,
                 rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """The benchmark's "point_cloud" observation of the settled object, resampled to `n` points.

    Raises:
        PerceptionError: the view holds no object points.
    """
    from manigrasp.bench.observe import observe_with_info

    observation, _ = observe_with_info("point_cloud", asset, object_pose, scene, seed=seed)
    return resample(observation.points, observation.normals, n, rng)
