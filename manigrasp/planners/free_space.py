"""Free, occupied and unknown space from depth images: what the camera rays passed through.

Pure NumPy. A `DepthView` is one depth frame with its pinhole intrinsics and
camera pose (OpenCV axes: x right, y down, z forward; camera-to-world (4, 4);
z-depth [m], NaN where nothing was measured). A point x of the world is
classified by projection into each view (the projective test of TSDF fusion,
Curless and Levoy 1996; VGN, Breyer et al. 2020): with z its depth along the
view's optical axis and d the depth measured at the pixel it falls in,

- FREE when z < d - tau: the ray to that pixel passed through x before it hit
  a surface (the surface is farther);
- OCCUPIED when |z - d| <= tau: x lies on the measured surface (within the
  noise band `tau`);
- UNKNOWN otherwise: behind the measured surface (occluded), outside the
  image, behind the camera, or at a pixel without depth.

A pixel without depth (a dropout) takes the nearest depth among its
neighbours within `FILL_RADIUS` pixels (the smallest: free space is only
claimed up to the nearest surface around it), so scattered dropouts do not
leave lines of unknown space through the free space.

Over several views a point is FREE if any view saw through it, else OCCUPIED
if any view saw it on a surface, else UNKNOWN (space carving: one ray through
a point proves it empty). `FreeSpace.voxels` samples the same test on a
regular grid (a voxel grid of the three states).

`ViewedObservation` is an `Observation` that carries the depth views its
cloud came from, so a planner can test its gripper against the space the
views did not see (`manigrasp.planners.partial`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from manigrasp.errors import PlannerError
from manigrasp.planners.base import Observation

FREE, OCCUPIED, UNKNOWN = 0, 1, 2
FILL_RADIUS = 2  # [px]
DEFAULT_TAU = 0.003  # [m], surface band: about 2.5 sigma of the default depth noise at 0.55 m


@dataclass(frozen=True, eq=False)
class DepthView:
    """One depth frame: z-depth (h, w) [m] (NaN: no measurement), intrinsics, camera-to-world pose (4, 4).

    Pixel (row i, column j) has its centre at u = j + 0.5, v = i + 0.5
    (`manigrasp.perception.camera.Intrinsics`).
    """

    depth: np.ndarray
    fx: float
    fy: float
    cx: float
    cy: float
    pose: np.ndarray

    def __post_init__(self) -> None:
        depth, pose = np.array(self.depth, float), np.array(self.pose, float)
        if depth.ndim != 2 or pose.shape != (4, 4) or not np.all(np.isfinite(pose)):
            raise PlannerError(f"a depth view needs a (h, w) depth and a finite (4, 4) pose, got "
                               f"{depth.shape} and {pose.shape}")
        depth.setflags(write=False)
        pose.setflags(write=False)
        object.__setattr__(self, "depth", depth)
        object.__setattr__(self, "pose", pose)
        object.__setattr__(self, "_filled", fill_dropouts(depth, FILL_RADIUS))

    @property
    def position(self) -> np.ndarray:
        """(3,) the camera centre in the world [m]."""
        return self.pose[:3, 3].copy()

    def classify(self, points: np.ndarray, tau: float) -> np.ndarray:
        """(n,) FREE / OCCUPIED / UNKNOWN of world `points` (n, 3) [m] in this view (module docstring)."""
        local = (np.asarray(points, float) - self.pose[:3, 3]) @ self.pose[:3, :3]
        z = local[:, 2]
        ahead = z > 1e-6
        safe_z = np.where(ahead, z, 1.0)
        u = np.floor(self.fx * local[:, 0] / safe_z + self.cx)
        v = np.floor(self.fy * local[:, 1] / safe_z + self.cy)
        h, w = self.depth.shape
        inside = ahead & (u >= 0) & (u < w) & (v >= 0) & (v < h)
        d = np.full(len(z), np.nan)
        d[inside] = self._filled[v[inside].astype(int), u[inside].astype(int)]
        out = np.full(len(z), UNKNOWN, np.int8)
        with np.errstate(invalid="ignore"):
            out[np.abs(z - d) <= tau] = OCCUPIED
            out[z < d - tau] = FREE
        return out


def fill_dropouts(depth: np.ndarray, radius: int) -> np.ndarray:
    """A copy of `depth` (h, w) [m] whose NaN pixels take the smallest depth within `radius` pixels
    (NaN where there is none)."""
    from scipy.ndimage import minimum_filter

    nearest = minimum_filter(np.where(np.isnan(depth), np.inf, depth), size=2 * radius + 1, mode="nearest")
    out = np.where(np.isnan(depth), nearest, depth)
    out[~np.isfinite(out)] = np.nan
    return out


@dataclass(frozen=True, eq=False)
class FreeSpace:
    """The space seen by one or more depth views (module docstring).

    Attributes:
        views: the depth views.
        tau: half-width of the surface band [m] (a few sigma of the depth noise).
    """

    views: tuple[DepthView, ...]
    tau: float = DEFAULT_TAU

    def __post_init__(self) -> None:
        object.__setattr__(self, "views", tuple(self.views))
        if not self.views:
            raise PlannerError("free space needs at least one depth view")
        if not self.tau > 0:
            raise PlannerError(f"the surface band tau must be > 0, got {self.tau}")

    def classify(self, points: np.ndarray) -> np.ndarray:
        """(n,) FREE / OCCUPIED / UNKNOWN of world `points` (n, 3) [m] over every view."""
        states = np.stack([view.classify(points, self.tau) for view in self.views])
        out = np.full(states.shape[1], UNKNOWN, np.int8)
        out[np.any(states == OCCUPIED, axis=0)] = OCCUPIED
        out[np.any(states == FREE, axis=0)] = FREE
        return out

    def free(self, points: np.ndarray) -> np.ndarray:
        """(n,) True where some view saw through the point."""
        states = [view.classify(points, self.tau) == FREE for view in self.views]
        return np.logical_or.reduce(states)

    def voxels(self, low: np.ndarray, high: np.ndarray, size: float) -> np.ndarray:
        """(nx, ny, nz) states of the voxel centres of the box [low, high] (3,) [m], voxel edge `size` [m]."""
        axes = [np.arange(lo + 0.5 * size, hi, size) for lo, hi in zip(low, high, strict=True)]
        grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)
        return self.classify(grid.reshape(-1, 3)).reshape(grid.shape[:3])


@dataclass(frozen=True, eq=False)
class ViewedObservation(Observation):
    """A point-cloud `Observation` with the depth views it came from (the free space around the object).

    Attributes:
        views: the depth frames (one per camera) the cloud was segmented from.
    """

    views: tuple[DepthView, ...] = ()

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "views", tuple(self.views))
        if self.points is None or not self.views:
            raise PlannerError("a viewed observation needs points, normals and at least one depth view")

    def free_space(self, tau: float = DEFAULT_TAU) -> FreeSpace:
        """The `FreeSpace` of its views."""
        return FreeSpace(self.views, tau)
