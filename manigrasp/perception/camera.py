"""A simulated depth camera: pinhole intrinsics, a pose, and depth by ray casting or by MuJoCo's renderer.

Camera frame (OpenCV): x right, y down, z forward (the optical axis). A
camera pose is the (4, 4) camera-to-world transform [m]. Depth is the
distance along the optical axis (z-depth) [m], as MuJoCo's renderer gives
it; a pixel that sees nothing is NaN.

Two backends produce the same `DepthImage`:

- "raycast": `mujoco.mj_multiRay` against the scene's geoms, one ray through
  each pixel centre. Needs no OpenGL: this is the path a headless CPU machine uses.
- "gl": `mujoco.Renderer` with a free camera at the same pose and field of
  view. Needs an OpenGL backend (EGL, OSMesa or GLFW, chosen by the
  ``MUJOCO_GL`` variable before mujoco is imported). `gl_available` says
  whether it works in this process.

Which backend ran is recorded in `DepthImage.backend`.
"""

from __future__ import annotations

import copy
import functools
import math
import os
from dataclasses import dataclass

import mujoco
import numpy as np

from manigrasp.errors import ConfigError
from manigrasp.geometry import rigid_defect

VISIBLE_GROUPS = (1, 1, 1, 0, 0, 0)  # geom groups MuJoCo's renderer shows by default: table, hand, object visual
BACKENDS = ("auto", "raycast", "gl")


@dataclass(frozen=True)
class Intrinsics:
    """Pinhole intrinsics; pixel (row i, column j) has its centre at u = j + 0.5, v = i + 0.5.

    Attributes:
        width, height: image size [px].
        fx, fy: focal lengths [px].
        cx, cy: principal point [px] (image centre: width / 2, height / 2).
    """

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float

    def __post_init__(self) -> None:
        if self.width < 1 or self.height < 1:
            raise ConfigError(f"camera resolution must be positive, got {self.width} x {self.height}")
        if not (self.fx > 0 and self.fy > 0):
            raise ConfigError(f"focal lengths must be > 0, got fx={self.fx}, fy={self.fy}")

    @classmethod
    def from_fovy(cls, width: int, height: int, fovy_deg: float) -> Intrinsics:
        """Square pixels, centred principal point, vertical field of view `fovy_deg` [deg] (MuJoCo's model)."""
        if not 0 < fovy_deg < 180:
            raise ConfigError(f"fovy must be in (0, 180) degrees, got {fovy_deg}")
        f = 0.5 * height / math.tan(math.radians(fovy_deg) / 2)
        return cls(width, height, f, f, width / 2, height / 2)

    @property
    def fovy_deg(self) -> float:
        """Vertical field of view [deg]."""
        return math.degrees(2 * math.atan(0.5 * self.height / self.fy))

    def pixel_rays(self) -> np.ndarray:
        """(height * width, 3) rays through the pixel centres, camera frame, z = 1 (row-major)."""
        v, u = np.mgrid[0:self.height, 0:self.width] + 0.5
        x = (u - self.cx) / self.fx
        y = (v - self.cy) / self.fy
        return np.stack([x.ravel(), y.ravel(), np.ones(x.size)], axis=1)


@dataclass(frozen=True)
class Camera:
    """A camera: intrinsics and its (4, 4) camera-to-world pose (OpenCV axes) [m]."""

    intrinsics: Intrinsics
    pose: np.ndarray

    def __post_init__(self) -> None:
        pose = np.array(self.pose, float)
        if pose.shape != (4, 4) or not np.all(np.isfinite(pose)):
            raise ConfigError(f"camera pose must be a finite (4, 4) matrix, got shape {pose.shape}")
        defect = rigid_defect(pose)
        if defect is not None:
            raise ConfigError(f"camera pose {defect}")
        pose.setflags(write=False)
        object.__setattr__(self, "pose", pose)

    @property
    def position(self) -> np.ndarray:
        """(3,) optical centre in the world [m]."""
        return self.pose[:3, 3].copy()

    def world_rays(self) -> np.ndarray:
        """(height * width, 3) per-pixel rays in the world, scaled so that z-depth 1 is the ray end."""
        return self.intrinsics.pixel_rays() @ self.pose[:3, :3].T


def look_at(eye: np.ndarray, target: np.ndarray, up: np.ndarray = (0.0, 0.0, 1.0)) -> np.ndarray:
    """(4, 4) camera-to-world pose at `eye` looking at `target` (OpenCV axes, image "up" toward `up`).

    Raises:
        ConfigError: eye == target, or the viewing direction parallel to `up`.
    """
    eye, target, up = (np.asarray(a, float) for a in (eye, target, up))
    forward = target - eye
    if np.linalg.norm(forward) < 1e-9:
        raise ConfigError("camera eye and target coincide")
    z = forward / np.linalg.norm(forward)
    x = np.cross(z, up)
    if np.linalg.norm(x) < 1e-9:
        raise ConfigError("camera looks along its up vector; choose another up or eye")
    x /= np.linalg.norm(x)
    pose = np.eye(4)
    pose[:3, :3] = np.column_stack([x, np.cross(z, x), z])
    pose[:3, 3] = eye
    return pose


def orbit_pose(target: np.ndarray, distance: float, azimuth_deg: float, elevation_deg: float) -> np.ndarray:
    """(4, 4) pose of a camera `distance` [m] from `target`, at `azimuth_deg` about world z
    (0: on the +x side) and `elevation_deg` above the horizontal, looking at `target`."""
    az, el = math.radians(azimuth_deg), math.radians(elevation_deg)
    offset = distance * np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
    return look_at(np.asarray(target, float) + offset, target)


@dataclass(frozen=True)
class DepthImage:
    """One depth frame.

    Attributes:
        depth: (height, width) z-depth [m]; NaN where nothing was hit (or dropped by noise).
        geom: (height, width) id of the geom seen at each pixel, -1 for none.
        camera: the camera that took it.
        backend: "raycast" or "gl": which one produced it.
    """

    depth: np.ndarray
    geom: np.ndarray
    camera: Camera
    backend: str


def raycast_depth(model: mujoco.MjModel, data: mujoco.MjData, camera: Camera,
                  geomgroup: tuple[int, ...] = VISIBLE_GROUPS, cutoff: float = 10.0) -> DepthImage:
    """Depth by `mj_multiRay` through every pixel centre against the geoms in `geomgroup` (valid after mj_forward).

    Args:
        cutoff: geoms farther than this [m] are not seen.
    """
    rays = camera.world_rays()
    norms = np.linalg.norm(rays, axis=1)
    unit = np.ascontiguousarray(rays / norms[:, None]).ravel()
    n = len(norms)
    geom = np.full(n, -1, np.int32)
    dist = np.full(n, -1.0)
    mujoco.mj_multiRay(model, data, camera.position, unit, np.asarray(geomgroup, np.uint8), True, -1,
                       geom, dist, None, n, cutoff)
    depth = np.where(geom >= 0, dist / norms, np.nan)  # along the ray -> along the optical axis
    shape = (camera.intrinsics.height, camera.intrinsics.width)
    return DepthImage(depth.reshape(shape), geom.reshape(shape).astype(int), camera, "raycast")


@functools.lru_cache(maxsize=1)
def gl_available() -> tuple[bool, str]:
    """Whether MuJoCo's renderer can make an OpenGL context in this process, and why not if it cannot.

    Tries once (cached): builds a tiny model and a 4 x 4 `mujoco.Renderer`.
    Returns (ok, message); the message names ``MUJOCO_GL`` and the error.
    """
    backend = os.environ.get("MUJOCO_GL", "(unset: glfw)")
    try:
        model = mujoco.MjModel.from_xml_string("<mujoco><worldbody><geom size='.1'/></worldbody></mujoco>")
        renderer = mujoco.Renderer(model, 4, 4)
        renderer.close()
    except Exception as exc:  # each GL backend fails its own way (FatalError, AttributeError, GLFWError...)
        return False, f"no OpenGL context with MUJOCO_GL={backend}: {type(exc).__name__}: {exc}"
    return True, f"MUJOCO_GL={backend}"


def _free_camera(pose: np.ndarray) -> mujoco.MjvCamera:
    """A free `MjvCamera` with the viewing direction of `pose` (it cannot roll: image up must be world up)."""
    z = pose[:3, 2]
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_FREE
    cam.distance = 1.0
    cam.lookat[:] = pose[:3, 3] + z
    cam.azimuth = math.degrees(math.atan2(z[1], z[0]))
    cam.elevation = math.degrees(math.asin(float(np.clip(z[2], -1, 1))))
    return cam


def render_depth(model: mujoco.MjModel, data: mujoco.MjData, camera: Camera) -> DepthImage:
    """Depth by MuJoCo's renderer (needs OpenGL; see `gl_available`), same pixels as `raycast_depth`.

    The renderer's camera has square pixels, a centred principal point and no
    roll (image up along world +z), so `camera` must too. The scene model is
    not modified (a copy gets the field of view and buffer size). Geom ids
    come from the segmentation render.

    Raises:
        ConfigError: GL is not available, or the camera cannot be rendered by MuJoCo.
    """
    ok, why = gl_available()
    if not ok:
        raise ConfigError(f"the GL depth backend is unavailable: {why}")
    k = camera.intrinsics
    if abs(k.fx - k.fy) > 1e-9 or abs(k.cx - k.width / 2) > 1e-9 or abs(k.cy - k.height / 2) > 1e-9:
        raise ConfigError("the GL backend needs square pixels and a centred principal point")
    if abs(camera.pose[2, 0]) > 1e-9:
        raise ConfigError("the GL backend's free camera cannot roll: build the pose with look_at(up=z)")
    local = copy.deepcopy(model)
    local.vis.global_.fovy = k.fovy_deg
    local.vis.global_.offwidth = max(local.vis.global_.offwidth, k.width)
    local.vis.global_.offheight = max(local.vis.global_.offheight, k.height)
    cam = _free_camera(camera.pose)
    option = mujoco.MjvOption()
    option.geomgroup[:] = VISIBLE_GROUPS
    with mujoco.Renderer(local, k.height, k.width) as renderer:
        renderer.enable_depth_rendering()
        renderer.update_scene(data, camera=cam, scene_option=option)
        depth = renderer.render().astype(float)
        renderer.disable_depth_rendering()
        renderer.enable_segmentation_rendering()
        renderer.update_scene(data, camera=cam, scene_option=option)
        seg = renderer.render()
    geom = np.where(seg[..., 1] == int(mujoco.mjtObj.mjOBJ_GEOM), seg[..., 0], -1).astype(int)
    depth = np.where(geom >= 0, depth, np.nan)
    return DepthImage(depth, geom, camera, "gl")


def capture(model: mujoco.MjModel, data: mujoco.MjData, camera: Camera, backend: str = "raycast") -> DepthImage:
    """A depth frame by `backend`: "raycast" (the default: the same on every machine), "gl", or "auto"
    (GL when available, else ray casting)."""
    if backend not in BACKENDS:
        raise ConfigError(f"unknown depth backend {backend!r}; available: {', '.join(BACKENDS)}")
    if backend == "gl" or (backend == "auto" and gl_available()[0]):
        return render_depth(model, data, camera)
    return raycast_depth(model, data, camera)
