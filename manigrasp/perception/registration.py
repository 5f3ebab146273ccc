"""Rigid registration: RANSAC on FPFH correspondences, then point-to-plane ICP (Open3D).

`register(source, target)` finds T (4, 4) with T @ source ~ target. The
pipeline registers the observed cloud (source, world frame) onto the model
(target, object frame, exact mesh normals), so `fitness` is the fraction of
observed points that the model explains and the object pose is inv(T).

Two errors of the textbook's version are avoided here: its coarse step
calls `registration_f_based_on_feature_matching`, which Open3D does not have
(RANSAC on feature matches is `registration_ransac_based_on_feature_matching`),
and its evaluation calls `source.transform(...)`, which moves the caller's
cloud in place; `evaluate` works on copies.

Seeding: Open3D's RANSAC draws from its own process-wide generator, which
`register` seeds from the given seed before each call (single-threaded RANSAC
would be needed for bit-exact repeats; see `global_registration`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from manigrasp.perception.features import o3d_cloud


@dataclass(frozen=True)
class RegistrationParams:
    """Thresholds of the coarse and fine steps, in multiples of `voxel`.

    Attributes:
        voxel: voxel size of the clouds [m].
        ransac_distance: inlier distance of RANSAC, in voxels.
        ransac_edge_ratio: edge-length similarity a sample must pass (0..1).
        ransac_max_iterations: RANSAC iteration cap.
        ransac_confidence: RANSAC stops early at this confidence.
        icp_coarse_distance: correspondence distance of the first ICP stage, in voxels (it pulls a
            rough RANSAC pose in from farther away).
        icp_distance: correspondence distance of the second ICP stage, in voxels.
        icp_max_iterations: ICP iteration cap.
        fitness_distance: a source point within this of the target is an inlier, in voxels.
    """

    voxel: float = 0.005
    ransac_distance: float = 1.5
    ransac_edge_ratio: float = 0.9
    ransac_max_iterations: int = 20_000
    ransac_confidence: float = 0.999
    icp_coarse_distance: float = 3.0
    icp_distance: float = 1.0
    icp_max_iterations: int = 50
    fitness_distance: float = 1.0


@dataclass(frozen=True)
class Registration:
    """A registration's outcome.

    Attributes:
        transform: (4, 4) T with T @ source ~ target.
        fitness: fraction of source points within the inlier distance of the target [0, 1].
        inlier_rmse: RMS distance of those inliers [m] (inf when there are none).
    """

    transform: np.ndarray
    fitness: float
    inlier_rmse: float


def _result(res) -> Registration:
    rmse = float(res.inlier_rmse) if res.fitness > 0 else float("inf")
    return Registration(np.asarray(res.transformation).copy(), float(res.fitness), rmse)


def global_registration(source: np.ndarray, source_features: np.ndarray, target: np.ndarray,
                        target_features: np.ndarray, params: RegistrationParams, seed: int) -> Registration:
    """Coarse T by RANSAC over mutual nearest FPFH matches (3-point samples, edge-length and
    distance checks); `source`/`target` (n, 3)/(m, 3), features (n, 33)/(m, 33)."""
    import open3d as o3d

    reg = o3d.pipelines.registration
    distance = params.ransac_distance * params.voxel
    feat_s, feat_t = reg.Feature(), reg.Feature()
    feat_s.data = np.ascontiguousarray(source_features.T, dtype=float)
    feat_t.data = np.ascontiguousarray(target_features.T, dtype=float)
    o3d.utility.random.seed(int(seed) % (2**31))
    # Open3D warns whenever the mutual filter leaves < 30 matches (it then falls back to all matches).
    with o3d.utility.VerbosityContextManager(o3d.utility.VerbosityLevel.Error):
        res = reg.registration_ransac_based_on_feature_matching(
            o3d_cloud(source), o3d_cloud(target), feat_s, feat_t, True, distance,
            reg.TransformationEstimationPointToPoint(False), 3,
            [reg.CorrespondenceCheckerBasedOnEdgeLength(params.ransac_edge_ratio),
             reg.CorrespondenceCheckerBasedOnDistance(distance)],
            reg.RANSACConvergenceCriteria(params.ransac_max_iterations, params.ransac_confidence))
    return _result(res)


def refine_icp(source: np.ndarray, target: np.ndarray, target_normals: np.ndarray, init: np.ndarray,
               params: RegistrationParams) -> Registration:
    """Point-to-plane ICP from `init` (4, 4), at the coarse then the fine correspondence distance;
    `target_normals` (m, 3) are the target's unit normals."""
    import open3d as o3d

    reg = o3d.pipelines.registration
    src, tgt = o3d_cloud(source), o3d_cloud(target, target_normals)
    transform = np.asarray(init, float)
    for distance in (params.icp_coarse_distance, params.icp_distance):
        res = reg.registration_icp(src, tgt, distance * params.voxel, transform,
                                   reg.TransformationEstimationPointToPlane(),
                                   reg.ICPConvergenceCriteria(max_iteration=params.icp_max_iterations))
        transform = np.asarray(res.transformation)
    return _result(res)


def evaluate(source: np.ndarray, target: np.ndarray, transform: np.ndarray, distance: float) -> Registration:
    """Fitness and inlier RMSE of `transform` applied to a copy of `source` (the caller's array is untouched)."""
    import open3d as o3d

    res = o3d.pipelines.registration.evaluate_registration(o3d_cloud(source), o3d_cloud(target), distance,
                                                           np.asarray(transform, float))
    return _result(res)


def register(source: np.ndarray, source_features: np.ndarray, target: np.ndarray, target_features: np.ndarray,
             target_normals: np.ndarray, params: RegistrationParams, seed: int,
             icp_target: tuple[np.ndarray, np.ndarray] | None = None) -> Registration:
    """RANSAC then point-to-plane ICP; ICP runs against `icp_target` = (points, normals) when given
    (a denser sampling of the target), else against `target`."""
    coarse = global_registration(source, source_features, target, target_features, params, seed)
    dense, dense_normals = icp_target if icp_target is not None else (target, target_normals)
    return refine_icp(source, dense, dense_normals, coarse.transform, params)
