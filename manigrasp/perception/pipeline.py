"""The perception pipeline end to end: camera frame -> noisy depth -> segmented cloud -> pose, with timings.

    >>> db = ModelDatabase.from_assets([asset])
    >>> result = perceive(model, data, object_geoms, camera, db, rng, true_pose=pose)
    >>> result.estimate.pose, result.errors.rotation_deg, result.timings

`tabletop` compiles a table and one object without a hand, for perception
on its own (tests, the `perceive` command); the benchmark uses its `Scene`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import mujoco
import numpy as np

from manigrasp.errors import ConfigError
from manigrasp.objects.asset import ObjectAsset
from manigrasp.perception import metrics
from manigrasp.perception.camera import Camera, DepthImage, Intrinsics, capture, orbit_pose
from manigrasp.perception.cloud import Cloud, object_cloud
from manigrasp.perception.models import Model, ModelDatabase
from manigrasp.perception.noise import DepthNoise, apply_noise
from manigrasp.perception.recognition import PoseEstimate, estimate_pose, observed_features, recognize
from manigrasp.perception.registration import RegistrationParams

ADD_S_THRESHOLD = 0.005  # [m] ADD-S below which the pose of a symmetric object counts as correct
ROTATION_THRESHOLD_DEG = 5.0
TRANSLATION_THRESHOLD_MM = 10.0


@dataclass(frozen=True)
class CameraConfig:
    """A camera orbiting the object (its pose from distance, azimuth and elevation about a target).

    Attributes:
        width, height: resolution [px].
        fovy_deg: vertical field of view [deg].
        distance: from the target [m].
        azimuth_deg: about world z, 0 on the +x side [deg].
        elevation_deg: above the table plane [deg].
        target_height: height of the target above the object's origin's table point [m].
        backend: "raycast", "gl" or "auto" (see `manigrasp.perception.camera`).
    """

    width: int = 320
    height: int = 240
    fovy_deg: float = 45.0
    distance: float = 0.55
    azimuth_deg: float = 30.0
    elevation_deg: float = 45.0
    target_height: float = 0.05
    backend: str = "raycast"

    def camera(self, target_xy: np.ndarray, table_height: float = 0.0) -> Camera:
        """The camera looking at (`target_xy`, table_height + target_height)."""
        target = np.array([target_xy[0], target_xy[1], table_height + self.target_height])
        return Camera(Intrinsics.from_fovy(self.width, self.height, self.fovy_deg),
                      orbit_pose(target, self.distance, self.azimuth_deg, self.elevation_deg))


@dataclass(frozen=True)
class PoseErrors:
    """Errors of an estimated pose against the truth (`manigrasp.perception.metrics`).

    Attributes:
        rotation_deg, translation_mm: orientation and origin errors.
        add_mm, add_s_mm: ADD and ADD-S over the model's samples [mm].
        symmetric: whether the object has a symmetry (then `success` uses ADD-S).
    """

    rotation_deg: float
    translation_mm: float
    add_mm: float
    add_s_mm: float
    symmetric: bool

    @property
    def success(self) -> bool:
        """Rotation < 5 deg and translation < 1 cm; a symmetric object: ADD-S < 5 mm and translation < 1 cm."""
        if self.translation_mm >= TRANSLATION_THRESHOLD_MM:
            return False
        if self.symmetric:
            return self.add_s_mm < 1000 * ADD_S_THRESHOLD
        return self.rotation_deg < ROTATION_THRESHOLD_DEG


def pose_errors(model: Model, true_pose: np.ndarray, est_pose: np.ndarray, max_points: int = 2000) -> PoseErrors:
    """All pose errors of `est_pose` for `model` at `true_pose` (both (4, 4)).

    ADD uses the model's samples; ADD-S measures from at most `max_points` of its dense samples to
    all of them (the dense spacing, half a voxel, bounds how far ADD-S stays from 0 at a symmetry).
    """
    dense = model.dense_points
    query = dense[np.linspace(0, len(dense) - 1, min(max_points, len(dense))).astype(int)]
    near = metrics.nearest_distances(query @ true_pose[:3, :3].T + true_pose[:3, 3],
                                     dense @ est_pose[:3, :3].T + est_pose[:3, 3])
    return PoseErrors(metrics.rotation_error_deg(true_pose, est_pose),
                      metrics.translation_error_mm(true_pose, est_pose),
                      1000 * metrics.add(model.points, true_pose, est_pose), 1000 * float(near.mean()), model.symmetric)


@dataclass(frozen=True)
class PerceptionResult:
    """One view's outcome.

    Attributes:
        image: the (noisy) depth frame.
        cloud: the segmented object cloud, world frame, normals toward the camera.
        estimate: the chosen pose hypothesis.
        recognized_as: the recognised model's name (None if below the threshold), or
            the given model's name when recognition was not asked for.
        errors: errors against `true_pose`, None if no truth was given.
        timings: seconds per stage: "depth", "cloud", "features", "registration" (RANSAC + ICP + verification).
    """

    image: DepthImage
    cloud: Cloud
    estimate: PoseEstimate
    recognized_as: str | None
    errors: PoseErrors | None
    timings: dict[str, float] = field(default_factory=dict)

    @property
    def backend(self) -> str:
        """Which depth backend ran ("raycast" or "gl")."""
        return self.image.backend


def observe_cloud(model: mujoco.MjModel, data: mujoco.MjData, object_geoms: np.ndarray, camera: Camera,
                  noise: DepthNoise, rng: np.random.Generator, backend: str = "raycast",
                  table_height: float = 0.0, timings: dict[str, float] | None = None) -> tuple[DepthImage, Cloud]:
    """A noisy frame of the scene and the object's segmented cloud (table removed) with normals."""
    timings = {} if timings is None else timings
    start = time.perf_counter()
    image = apply_noise(capture(model, data, camera, backend), noise, rng)
    timings["depth"] = time.perf_counter() - start
    start = time.perf_counter()
    cloud = object_cloud(image, object_geoms, table_height)
    timings["cloud"] = time.perf_counter() - start
    return image, cloud


def perceive(model: mujoco.MjModel, data: mujoco.MjData, object_geoms: np.ndarray, camera: Camera,
             database: ModelDatabase, rng: np.random.Generator, object_name: str | None = None,
             true_pose: np.ndarray | None = None, noise: DepthNoise | None = None,
             params: RegistrationParams | None = None, restarts: int = 4, threshold: float = 0.7,
             backend: str = "raycast", table_height: float = 0.0) -> PerceptionResult:
    """One view: depth, cloud, then the pose of `object_name` (a known model), or, if None, recognition
    among every model of `database`. `true_pose` (4, 4), if given, gives the errors (of the known or
    the recognised model; of the true object's model if recognition picked another)."""
    params = params or RegistrationParams(voxel=database.params.voxel)
    noise = noise or DepthNoise()
    timings: dict[str, float] = {}
    image, cloud = observe_cloud(model, data, object_geoms, camera, noise, rng, backend, table_height, timings)
    start = time.perf_counter()
    if object_name is not None:
        observed = observed_features(cloud, database)
        timings["features"] = time.perf_counter() - start
        start = time.perf_counter()
        estimate = estimate_pose(database.get(object_name), observed, image, params, rng, restarts, table_height)
        recognized_as: str | None = object_name
    else:
        result = recognize(database, cloud, image, params, rng, threshold, restarts, table_height)
        if result.best is None:
            raise ConfigError("no model of the database fits the size of the observed cloud")
        estimate, recognized_as = result.best, result.name
        timings["features"] = 0.0  # computed inside recognition, counted with registration
    timings["registration"] = time.perf_counter() - start
    errors = None
    if true_pose is not None:
        errors = pose_errors(database.get(estimate.name), true_pose, estimate.pose)
    return PerceptionResult(image, cloud, estimate, recognized_as, errors, timings)


@dataclass(frozen=True, eq=False)
class Tabletop:
    """A table (top at z = 0) and one free object, no hand: `model`, `data`, the object's geoms."""

    model: mujoco.MjModel
    data: mujoco.MjData
    object_geoms: np.ndarray
    object_body: int

    def place(self, pose: np.ndarray) -> None:
        """Put the object at `pose` (4, 4) and run `mj_forward`."""
        from manigrasp.sim.transforms import mat_to_quat

        adr = self.model.jnt_qposadr[self.model.body_jntadr[self.object_body]]
        self.data.qpos[adr:adr + 3] = pose[:3, 3]
        self.data.qpos[adr + 3:adr + 7] = mat_to_quat(pose[:3, :3])
        mujoco.mj_forward(self.model, self.data)


def tabletop(asset: ObjectAsset, table_half_extents: tuple[float, float, float] = (0.4, 0.4, 0.02)) -> Tabletop:
    """Compile a table box (top at z = 0) and `asset` (prefixed ``object/`` as in `manigrasp.sim`)."""
    spec = mujoco.MjSpec()
    half = np.asarray(table_half_extents, float)
    spec.worldbody.add_geom(name="table/top", type=mujoco.mjtGeom.mjGEOM_BOX, size=half, pos=[0, 0, -half[2]])
    child = mujoco.MjSpec.from_file(str(asset.mjcf_path))
    spec.worldbody.add_frame().attach_body(child.body("object"), "object/", "")
    model = spec.compile()
    body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "object/object")
    return Tabletop(model, mujoco.MjData(model), np.flatnonzero(model.geom_bodyid == body), body)
