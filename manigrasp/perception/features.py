"""Voxel down-sampling and FPFH features (Rusu, Blodow and Beetz 2009) through Open3D.

Feature and normal radii scale with the voxel size (the textbook's fixed
0.1 m / 0.15 m radii span whole YCB objects and make every point alike).
Needs the `perception` extra (open3d); it is imported inside the functions.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class FeatureParams:
    """Down-sampling and feature radii.

    Attributes:
        voxel: voxel size of the down-sampled clouds [m].
        feature_radius: FPFH search radius, in voxels.
        feature_max_nn: at most this many neighbours per FPFH.
    """

    voxel: float = 0.005
    feature_radius: float = 5.0
    feature_max_nn: int = 100


def o3d_cloud(points: np.ndarray, normals: np.ndarray | None = None):
    """An `open3d.geometry.PointCloud` of (n, 3) `points` [m] and optional (n, 3) `normals`."""
    import open3d as o3d

    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.asarray(points, float)))
    if normals is not None:
        pcd.normals = o3d.utility.Vector3dVector(np.asarray(normals, float))
    return pcd


def downsample(points: np.ndarray, normals: np.ndarray, voxel: float,
               average: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Voxel-grid down-sampling to one point per occupied `voxel` [m] cell. Returns ((m, 3), (m, 3)).

    average=True: the cell's centroid and mean normal (renormalised): for a
    one-sided cloud seen by a camera. average=False: the cell's first input
    point with its own normal: for model samples, where a thin wall puts
    opposite normals in one cell and their mean would be meaningless.
    """
    if not average:
        keys = np.floor(np.asarray(points, float) / voxel).astype(np.int64)
        _, first = np.unique(keys, axis=0, return_index=True)
        first = np.sort(first)
        return np.asarray(points, float)[first].copy(), np.asarray(normals, float)[first].copy()
    pcd = o3d_cloud(points, normals).voxel_down_sample(voxel)
    out_normals = np.asarray(pcd.normals)
    out_normals = out_normals / np.maximum(np.linalg.norm(out_normals, axis=1, keepdims=True), 1e-12)
    return np.asarray(pcd.points).copy(), out_normals


def fpfh(points: np.ndarray, normals: np.ndarray, params: FeatureParams | None = None) -> np.ndarray:
    """(n, 33) FPFH descriptors of `points` (n, 3) with their `normals` (n, 3)."""
    params = params or FeatureParams()
    import open3d as o3d

    search = o3d.geometry.KDTreeSearchParamHybrid(radius=params.feature_radius * params.voxel,
                                                  max_nn=params.feature_max_nn)
    feature = o3d.pipelines.registration.compute_fpfh_feature(o3d_cloud(points, normals), search)
    return np.asarray(feature.data).T.copy()
