"""Several depth views of one object fused into one cloud and one free-space model.

Each view is captured, made noisy and segmented on its own
(as `pipeline.observe_cloud`: its normals turned toward its own camera); the
fused cloud is the union of the views' object points (world frame), and the
depth frames become `free_space.DepthView`s whose projective test says which
space any camera saw through (`manigrasp.planners.free_space`). View i's
noise comes from its own generator, so adding a view leaves the others'
frames unchanged.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from manigrasp.errors import ConfigError
from manigrasp.perception.camera import Camera, DepthImage, capture
from manigrasp.perception.cloud import Cloud, object_cloud
from manigrasp.perception.noise import apply_noise
from manigrasp.perception.pipeline import PerceptionConfig, Viewed, object_geoms
from manigrasp.planners.free_space import DepthView


@dataclass(frozen=True)
class FusedViews:
    """Views of one object: the frames, each view's cloud (None where the object was not in view), the fused cloud."""

    images: tuple[DepthImage, ...]
    clouds: tuple[Cloud | None, ...]
    cloud: Cloud

    def depth_views(self) -> tuple[DepthView, ...]:
        """Every frame as a `DepthView` (the free space of all views)."""
        return tuple(depth_view(image) for image in self.images)


def depth_view(image: DepthImage) -> DepthView:
    """The `DepthView` of a depth frame (its depth, intrinsics and camera pose)."""
    k = image.camera.intrinsics
    return DepthView(image.depth, k.fx, k.fy, k.cx, k.cy, image.camera.pose)


def fuse_clouds(clouds: list[Cloud]) -> Cloud:
    """The union of `clouds` (world frame; each one's normals already face its own camera).

    The fused cloud's viewpoint is the first cloud's.

    Raises:
        ConfigError: no cloud given.
    """
    if not clouds:
        raise ConfigError("no view sees the object")
    return Cloud(np.vstack([c.points for c in clouds]), np.vstack([c.normals for c in clouds]),
                 clouds[0].viewpoint)


def observe_views(scene: Viewed, cameras: tuple[Camera, ...], rngs: list[np.random.Generator],
                  config: PerceptionConfig | None = None) -> FusedViews:
    """Capture every camera of `scene` (positions computed) with the noise, backend and table height of
    `config` (default `PerceptionConfig()`; noise from each camera's own generator in `rngs`), segment each
    view, fuse the clouds.

    Raises:
        ConfigError: no camera sees the object, or `rngs` and `cameras` differ in length.
    """
    if len(rngs) != len(cameras):
        raise ConfigError(f"{len(cameras)} cameras need as many generators, got {len(rngs)}")
    config = config or PerceptionConfig()
    labels = object_geoms(scene)
    images, clouds = [], []
    for camera, rng in zip(cameras, rngs, strict=True):
        image = apply_noise(capture(scene.model, scene.data, camera, config.backend), config.noise, rng)
        try:
            cloud = object_cloud(image, labels, config.table_height)
        except ConfigError:  # this camera does not see the object: its frame still shows free space
            cloud = None
        images.append(image)
        clouds.append(cloud)
    return FusedViews(tuple(images), tuple(clouds), fuse_clouds([c for c in clouds if c is not None]))
