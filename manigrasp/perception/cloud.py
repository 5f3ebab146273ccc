"""From a depth frame to a point cloud in the world: back-projection, segmentation, table removal, normals.

Points are (n, 3) float in the world frame [m]; normals (n, 3) unit vectors
oriented toward the camera (outward on a surface the camera sees).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from manigrasp.errors import ConfigError
from manigrasp.perception.camera import DepthImage


@dataclass(frozen=True)
class Cloud:
    """A point cloud.

    Attributes:
        points: (n, 3) points, world frame [m].
        normals: (n, 3) unit normals, or None before estimation.
        viewpoint: (3,) the camera centre the points were seen from [m].
    """

    points: np.ndarray
    normals: np.ndarray | None
    viewpoint: np.ndarray

    def __len__(self) -> int:
        return len(self.points)


def backproject(image: DepthImage, mask: np.ndarray | None = None) -> np.ndarray:
    """(n, 3) world points of the pixels with depth (and `mask`, (height, width) bool, if given)."""
    cam = image.camera
    valid = np.isfinite(image.depth)
    if mask is not None:
        valid &= mask
    rays = cam.intrinsics.pixel_rays()[valid.ravel()]
    local = rays * image.depth[valid][:, None]
    return local @ cam.pose[:3, :3].T + cam.pose[:3, 3]


def geom_mask(image: DepthImage, geoms: np.ndarray) -> np.ndarray:
    """(height, width) True where the pixel sees one of `geoms` (segmentation by geom id)."""
    return np.isin(image.geom, np.asarray(geoms, int))


def above_table(points: np.ndarray, table_height: float = 0.0, margin: float = 0.004) -> np.ndarray:
    """(n,) True for points more than `margin` [m] above the table plane z = `table_height`."""
    return np.asarray(points, float)[:, 2] > table_height + margin


def estimate_normals(points: np.ndarray, viewpoint: np.ndarray, radius: float | None = 0.01,
                     max_nn: int = 30) -> np.ndarray:
    """(n, 3) unit normals by local PCA (Open3D: the neighbours within `radius` [m], at most `max_nn`
    of them; `radius` None: the `max_nn` nearest), flipped to face `viewpoint` (3,) [m]. The one
    normal estimate of the package (perception and the planners' tests). Needs the `perception`
    extra (open3d)."""
    import open3d as o3d

    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.asarray(points, float)))
    search = (o3d.geometry.KDTreeSearchParamKNN(knn=max_nn) if radius is None
              else o3d.geometry.KDTreeSearchParamHybrid(radius=radius, max_nn=max_nn))
    pcd.estimate_normals(search)
    pcd.orient_normals_towards_camera_location(np.asarray(viewpoint, float))
    return np.asarray(pcd.normals).copy()


def object_cloud(image: DepthImage, object_geoms: np.ndarray, table_height: float = 0.0,
                 table_margin: float = 0.004, normal_radius: float = 0.01) -> Cloud:
    """The object's points in `image` (segmented by geom id, table removed) with normals toward the camera.

    Raises:
        ConfigError: fewer than 10 object points are left (the object is not in view).
    """
    points = backproject(image, geom_mask(image, object_geoms))
    points = points[above_table(points, table_height, table_margin)]
    if len(points) < 10:
        raise ConfigError(f"the object is not in the camera's view ({len(points)} object points)")
    normals = estimate_normals(points, image.camera.position, normal_radius)
    return Cloud(points, normals, image.camera.position)


def scene_cloud(image: DepthImage, table_height: float = 0.0, table_margin: float = 0.004,
                normal_radius: float = 0.01, max_height: float = 0.4) -> Cloud:
    """Everything the camera sees above the table (and below `max_height` [m], which leaves out a
    parked hand), with normals: the input of recognition when nothing says which points are the object."""
    points = backproject(image)
    keep = above_table(points, table_height, table_margin) & (points[:, 2] < table_height + max_height)
    points = points[keep]
    if len(points) < 10:
        raise ConfigError(f"nothing above the table in the camera's view ({len(points)} points)")
    normals = estimate_normals(points, image.camera.position, normal_radius)
    return Cloud(points, normals, image.camera.position)
