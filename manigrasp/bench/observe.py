"""What a planner sees of the settled object, per the config's `observation` switch.

- "ground_truth": the object's mesh at its true pose.
- "estimated_pose": the object's mesh (and collision parts) placed at the pose
  that the perception pipeline estimates from one noisy depth view (FPFH +
  RANSAC + ICP against the object's own model: the object's identity is
  given, its pose is not). The trial itself still runs on the true physics.
- "point_cloud": the raw segmented cloud of every camera of the setup,
  fused (`manigrasp.perception.fusion`), world frame, table removed, normals
  estimated and oriented toward each point's camera, with the depth frames
  themselves (a `free_space.ViewedObservation`: the antipodal planner's
  default ``completion="free_space"`` tests the hand against the space no
  camera saw through). Its `object_pose` has the identity rotation and the
  centroid of the points as origin: nothing of the true pose leaks to the planner.

The cameras are a `manigrasp.perception.setup.CameraSetup` (default: one
camera at azimuth 30 deg, elevation 45 deg, 0.55 m) aimed at the object's
resting position; "estimated_pose" uses its first camera. Camera 0's noise is
drawn from a generator seeded by (`seed`, object name), camera i's by
(`seed`, object name, i), so a group sees the same frames every time it is
planned and a second camera leaves the first one's frame unchanged.

The cameras look at the scene with the hand out of their view: a copy of the
settled state with the hand lifted `HAND_CLEARANCE` straight up, as a robot
retracts its arm before it captures a view. (The settle parks the open hand
0.6 m above the table; seen from there, an Allegro hid the whole object from a
camera at 85 deg elevation and 0.8 m.) The simulation's own state is not
touched.
"""

from __future__ import annotations

import copy
import math
import zlib
from dataclasses import dataclass

import mujoco
import numpy as np

from manigrasp.errors import ConfigError, ManigraspError, PerceptionError

KINDS = ("ground_truth", "estimated_pose", "point_cloud")
HAND_CLEARANCE = 20.0  # [m] the hand is lifted this far above the scene while the cameras look (module docstring)


@dataclass(frozen=True)
class ObservationInfo:
    """How an observation was made, and how far its pose is from the truth (NaN where not applicable).

    Attributes:
        kind: the observation kind.
        rotation_error_deg, translation_error_mm, add_mm, add_s_mm: errors of the estimated pose ("estimated_pose").
        symmetric: whether the estimated object has a symmetry (its pose is then judged by ADD-S,
            `manigrasp.perception.metrics.pose_good`); None where no pose was estimated.
        fitness: fraction of observed points the placed model explains.
        n_points: points in the segmented cloud (0 for ground truth).
        backend: depth backend that ran ("" for ground truth).
        camera: the camera setup of a perception kind (None for ground truth); `camera.record()` gives
            its flat fields (views, azimuths, elevation, distance, noise).
    """

    kind: str
    rotation_error_deg: float = math.nan
    translation_error_mm: float = math.nan
    add_s_mm: float = math.nan
    add_mm: float = math.nan
    symmetric: bool | None = None
    fitness: float = math.nan
    n_points: int = 0
    backend: str = ""
    camera: object = None


_DATABASES: dict[tuple[str, str], object] = {}  # (name, visual mesh path) -> ModelDatabase, per process


def _database(asset):
    from manigrasp.perception.models import ModelDatabase

    key = (asset.name, str(asset.visual_path))
    if key not in _DATABASES:
        _DATABASES[key] = ModelDatabase.from_assets([asset])
    return _DATABASES[key]


def view_rngs(seed: int, name: str, views: int) -> list[np.random.Generator]:
    """The noise generator of each camera: (`seed`, crc32(`name`)) for camera 0, with the camera's index after."""
    key = zlib.crc32(name.encode())
    return [np.random.default_rng([seed, key] if i == 0 else [seed, key, i]) for i in range(views)]


def observe_with_info(kind: str, asset, object_pose: np.ndarray, scene=None, seed: int = 0,
                      table_height: float = 0.0, camera=None):
    """(`Observation`, `ObservationInfo`) of `asset` resting at `object_pose` (4, 4) in `scene`.

    Args:
        camera: the `manigrasp.perception.setup.CameraSetup` of the perception kinds (None: the default).

    Raises:
        ConfigError: unknown kind, a perception kind without a scene, or `camera` not a CameraSetup.
        PerceptionError: perception failed on this view (the object is not in view, no model fits).
    """
    from manigrasp.planners.base import Observation

    if kind not in KINDS:
        raise ConfigError(f"unknown observation {kind!r}; available: {', '.join(KINDS)}")
    if kind == "ground_truth":
        return Observation.from_asset(asset, object_pose, table_height), ObservationInfo(kind)
    if scene is None:
        raise ConfigError(f"observation {kind!r} needs the simulated scene to take a depth image of")
    from manigrasp.perception.setup import CameraSetup

    setup = CameraSetup() if camera is None else camera
    if not isinstance(setup, CameraSetup):
        raise ConfigError(f"camera must be a CameraSetup, got {type(setup).__name__}")
    scene.forward()  # the simulation's own data as every run before computed it here (its derived quantities)
    scene = hand_out_of_view(scene)
    cameras = setup.cameras(object_pose[:2, 3], table_height)
    rngs = view_rngs(seed, asset.name, setup.views)
    try:
        if kind == "point_cloud":
            return _point_cloud(scene, cameras, setup, rngs, table_height)
        from manigrasp.perception.pipeline import perceive

        result = perceive(scene, cameras[0], _database(asset), rngs[0], setup.perception(table_height),
                          object_name=asset.name, true_pose=object_pose)
    except PerceptionError:
        raise
    except ManigraspError as exc:  # a failure on this view (object not in view...): the group's result
        raise PerceptionError(f"{kind} of {asset.name}: {exc}") from exc
    if len(result.cloud) == 0:
        raise PerceptionError(f"{kind} of {asset.name}: the view holds no object points")
    errors = result.errors
    info = ObservationInfo(kind, errors.rotation_deg, errors.translation_mm, errors.add_s_mm, errors.add_mm,
                           errors.symmetric, result.estimate.fitness, len(result.cloud), result.backend, setup)
    return Observation.from_asset(asset, result.estimate.pose, table_height), info


@dataclass(frozen=True)
class CameraView:
    """What the cameras see of a scene (`manigrasp.perception.pipeline.Viewed`): its model, a copy of its data with
    positions computed, and the object's body."""

    model: mujoco.MjModel
    data: mujoco.MjData
    object_body: int


def hand_out_of_view(scene) -> CameraView:
    """`scene` as its cameras see it (positions computed): a copy of its state with the hand lifted `HAND_CLEARANCE`
    straight up by the base's slide joints (module docstring); a scene without a hand as it is."""
    data = copy.copy(scene.data)
    base = getattr(scene, "base", None)
    if base is not None:
        mujoco.mj_kinematics(scene.model, data)
        slides = scene.model.dof_jntid[base.dofs[:3]]
        axes = data.xaxis[slides]  # the world directions of mount/tx, ty, tz
        lift = np.linalg.lstsq(axes.T, np.array([0.0, 0.0, HAND_CLEARANCE]), rcond=None)[0]
        data.qpos[scene.model.jnt_qposadr[slides]] += lift
    mujoco.mj_forward(scene.model, data)
    return CameraView(scene.model, data, scene.object_body)


def _point_cloud(scene, cameras: tuple, setup, rngs: list, table_height: float):
    """The fused cloud of every camera with its depth views (module docstring)."""
    from manigrasp.perception.fusion import observe_views
    from manigrasp.planners.free_space import ViewedObservation

    fused = observe_views(scene, cameras, rngs, setup.perception(table_height))
    pose = np.eye(4)
    pose[:3, 3] = fused.cloud.points.mean(axis=0)
    observation = ViewedObservation(object_pose=pose, points=fused.cloud.points, normals=fused.cloud.normals,
                                    table_height=table_height, views=fused.depth_views())
    info = ObservationInfo("point_cloud", n_points=len(fused.cloud), backend=fused.images[0].backend,
                           camera=setup)
    return observation, info


def observe(kind: str, asset, object_pose: np.ndarray, scene=None, seed: int = 0, camera=None):
    """The `Observation` of `asset` resting at `object_pose` (4, 4); see `observe_with_info`."""
    return observe_with_info(kind, asset, object_pose, scene, seed, camera=camera)[0]
