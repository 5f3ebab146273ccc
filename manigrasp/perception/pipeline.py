"""The perception pipeline end to end: camera frame -> noisy depth -> segmented cloud -> pose, with timings.

    >>> table = manigrasp.sim.build_tabletop(asset)
    >>> table.place(pose)
    >>> db = ModelDatabase.from_assets([asset])
    >>> result = perceive(table, camera, db, rng, PerceptionConfig(backend="raycast"), true_pose=pose)
    >>> result.estimate.pose, result.errors.rotation_deg, result.timings

The scene is composed by `manigrasp.sim`: a `manigrasp.sim.Tabletop` (the
table and one object, no hand: tests, the `perceive` command) or the
benchmark's `manigrasp.sim.Scene`. The camera labels every geom of the
object's body (visual and collision) as the object.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Protocol

import mujoco
import numpy as np

from manigrasp.errors import ConfigError
from manigrasp.perception import metrics
from manigrasp.perception.camera import BACKENDS, Camera, DepthImage, Intrinsics, capture, orbit_pose
from manigrasp.perception.cloud import Cloud, object_cloud
from manigrasp.perception.models import Model, ModelDatabase
from manigrasp.perception.noise import DepthNoise, apply_noise
from manigrasp.perception.recognition import (
    PoseEstimate,
    draw_seed,
    estimate_pose,
    model_rng,
    observed_features,
    recognize,
)
from manigrasp.perception.registration import RegistrationParams


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

    def __post_init__(self) -> None:
        if not (self.width >= 1 and self.height >= 1 and 0.0 < self.fovy_deg < 180.0):
            raise ConfigError(f"camera: width and height must be >= 1 px and fovy_deg in (0, 180), got "
                              f"{self.width} x {self.height}, {self.fovy_deg}")
        if not (np.isfinite(self.distance) and self.distance > 0):  # 0 or less: the camera at or behind its target
            raise ConfigError(f"camera: distance must be > 0 m, got {self.distance}")
        if not (np.isfinite(self.azimuth_deg) and np.isfinite(self.elevation_deg) and np.isfinite(self.target_height)):
            raise ConfigError("camera: azimuth_deg, elevation_deg and target_height must be finite numbers")

    def camera(self, target_xy: np.ndarray, table_height: float = 0.0) -> Camera:
        """The camera looking at (`target_xy`, table_height + target_height)."""
        target = np.array([target_xy[0], target_xy[1], table_height + self.target_height])
        return Camera(Intrinsics.from_fovy(self.width, self.height, self.fovy_deg),
                      orbit_pose(target, self.distance, self.azimuth_deg, self.elevation_deg))


class Viewed(Protocol):
    """What a camera needs of a compiled scene (a `manigrasp.sim.Scene` or `manigrasp.sim.Tabletop`)."""

    model: mujoco.MjModel
    data: mujoco.MjData
    object_body: int


def object_geoms(scene: Viewed) -> np.ndarray:
    """Ids of every geom of the scene's object body (visual and collision): the pixels labelled as the object."""
    return np.flatnonzero(scene.model.geom_bodyid == scene.object_body)


@dataclass(frozen=True)
class PerceptionConfig:
    """How one view is taken and interpreted (everything of `perceive` but the scene, camera and truth).

    Attributes:
        noise: the depth noise model.
        registration: thresholds of RANSAC + ICP; None: the defaults at the model database's voxel size.
        restarts: RANSAC restarts per model (the best verified one is kept).
        threshold: score a recognised model must reach, in [0, 1] (recognition only).
        backend: depth backend, "raycast", "gl" or "auto" (`manigrasp.perception.camera`).
        table_height: height of the table's top [m] (points at or below it are the table).
    """

    noise: DepthNoise = field(default_factory=DepthNoise)
    registration: RegistrationParams | None = None
    restarts: int = 4
    threshold: float = 0.7
    backend: str = "raycast"
    table_height: float = 0.0

    def __post_init__(self) -> None:
        if not isinstance(self.noise, DepthNoise):
            raise ConfigError(f"noise must be a DepthNoise, got {type(self.noise).__name__}")
        if self.registration is not None and not isinstance(self.registration, RegistrationParams):
            raise ConfigError(f"registration must be RegistrationParams or None, got "
                              f"{type(self.registration).__name__}")
        if isinstance(self.restarts, bool) or not isinstance(self.restarts, int) or self.restarts < 1:
            raise ConfigError(f"restarts must be an integer >= 1, got {self.restarts!r}")
        if not 0.0 <= self.threshold <= 1.0:
            raise ConfigError(f"threshold must be in [0, 1], got {self.threshold}")
        if self.backend not in BACKENDS:
            raise ConfigError(f"unknown backend {self.backend!r}; available: {', '.join(BACKENDS)}")
        if not math.isfinite(self.table_height):
            raise ConfigError(f"table_height must be finite, got {self.table_height}")


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
        """Rotation < 5 deg and translation < 1 cm; a symmetric object: ADD-S < 5 mm and translation < 1 cm
        (`metrics.pose_good`)."""
        return metrics.pose_good(self.rotation_deg, self.translation_mm, self.add_s_mm, self.symmetric)


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
        timings: seconds per stage: "depth", "cloud", then, given the object's name, "features" (the observed
            cloud's FPFH) and "registration" (RANSAC + ICP + verification), else "recognition" (features and
            registration against every model of the database, not split).
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


def observe_cloud(scene: Viewed, camera: Camera, rng: np.random.Generator, config: PerceptionConfig,
                  timings: dict[str, float] | None = None) -> tuple[DepthImage, Cloud]:
    """A noisy frame of `scene` (positions computed) and the object's segmented cloud (table removed) with
    normals; `timings` (if given) gets the seconds of "depth" and "cloud"."""
    timings = {} if timings is None else timings
    start = time.perf_counter()
    image = apply_noise(capture(scene.model, scene.data, camera, config.backend), config.noise, rng)
    timings["depth"] = time.perf_counter() - start
    start = time.perf_counter()
    cloud = object_cloud(image, object_geoms(scene), config.table_height)
    timings["cloud"] = time.perf_counter() - start
    return image, cloud


def perceive(scene: Viewed, camera: Camera, database: ModelDatabase, rng: np.random.Generator,
             config: PerceptionConfig | None = None, *, object_name: str | None = None,
             true_pose: np.ndarray | None = None) -> PerceptionResult:
    """One view of `scene` (positions computed) by `camera`: depth, cloud, then the pose of `object_name`
    (a known model), or, if None, recognition among every model of `database`, as `config` (default
    `PerceptionConfig()`) says. `true_pose` (4, 4), if given, gives the errors, measured on the model the
    estimate is of (the known one, or the recognised one: if recognition picked another object than the true one,
    they compare two models' poses and mean little; `manigrasp perceive` then does not print them)."""
    config = config or PerceptionConfig()
    params = config.registration or RegistrationParams(voxel=database.params.voxel)
    restarts, table_height = config.restarts, config.table_height
    timings: dict[str, float] = {}
    image, cloud = observe_cloud(scene, camera, rng, config, timings)
    start = time.perf_counter()
    if object_name is not None:
        observed = observed_features(cloud, database)
        timings["features"] = time.perf_counter() - start
        start = time.perf_counter()
        estimate = estimate_pose(database.get(object_name), observed, image, params,
                                 model_rng(draw_seed(rng), object_name), restarts, table_height)
        recognized_as: str | None = object_name
    else:
        result = recognize(database, cloud, image, params, rng, config.threshold, restarts, table_height)
        if result.best is None:
            raise ConfigError("no model of the database fits the size of the observed cloud")
        estimate, recognized_as = result.best, result.name
    timings["registration" if object_name is not None else "recognition"] = time.perf_counter() - start
    errors = None
    if true_pose is not None:
        errors = pose_errors(database.get(estimate.name), true_pose, estimate.pose)
    return PerceptionResult(image, cloud, estimate, recognized_as, errors, timings)
