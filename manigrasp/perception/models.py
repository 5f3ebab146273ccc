"""The model database: each object's surface samples, normals and FPFH features, and its symmetries.

A model lives in its object frame (origin at the centre of mass, the frame
of `ObjectAsset.visual_path`). Surface samples come from the visual mesh
with exact face normals; `points`/`normals`/`features` are down-sampled to
the feature voxel (RANSAC), `dense_points`/`dense_normals` to half of it (ICP).

Symmetry is measured, not declared: an object is symmetric if one of a set
of proper rotations about its centre of mass (90 and 180 degrees about each
object axis, and 37 degrees about each axis as a probe of a continuous
symmetry) maps its dense samples onto themselves to within `SYMMETRY_TOLERANCE`
(symmetric Hausdorff distance). Symmetric objects are judged by ADD-S.

Near-symmetries are measured too: rigid transforms, neither the identity nor
a symmetry, that map most of the model (`NEAR_SYMMETRY_FITNESS` of its
samples) onto its surface, e.g. a mug turned about its body's axis, the
handle elsewhere. A view of the symmetric part fits each of them about as
well as the true pose, and FPFH features of that part do not tell them
apart, so pose estimation tries every one of them on each hypothesis and lets
verification (where the handle is seen) choose; see
`manigrasp.perception.recognition`.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np
import trimesh

from manigrasp.errors import UnknownNameError
from manigrasp.geometry import pose_distance
from manigrasp.objects.asset import ObjectAsset
from manigrasp.perception.features import FeatureParams, downsample, fpfh, o3d_cloud
from manigrasp.perception.metrics import nearest_distances
from manigrasp.perception.registration import RegistrationParams, refine_icp

SYMMETRY_TOLERANCE = 0.006  # [m] Hausdorff distance below which a rotation maps the model onto itself
SAMPLES = 30_000  # surface samples per model before down-sampling
_PROBE_ANGLES_DEG = (90.0, 180.0, 37.0)
NEAR_SYMMETRY_FITNESS = 0.75  # fraction of samples a near-symmetry maps to within a voxel of the surface
NEAR_SYMMETRY_STEP_DEG = 30.0  # spacing of the rotations near-symmetries are searched from


@dataclass(frozen=True, eq=False)
class Model:
    """One object of the database (object frame).

    Attributes:
        name: object name.
        points, normals: (n, 3) samples at the feature voxel [m] and their outward unit normals.
        features: (n, 33) FPFH descriptors of `points`.
        dense_points, dense_normals: (m, 3) samples at half the voxel, for ICP.
        symmetries: (k, 3, 3) the probe rotations that map the model onto itself (possibly none).
        diameter: largest distance between two samples [m].
        near_symmetries: (j, 4, 4) rigid transforms of the object frame that map most of the model onto
            itself but are not symmetries (`find_near_symmetries`; possibly none).
    """

    name: str
    points: np.ndarray
    normals: np.ndarray
    features: np.ndarray
    dense_points: np.ndarray
    dense_normals: np.ndarray
    symmetries: np.ndarray
    diameter: float
    near_symmetries: np.ndarray = field(default_factory=lambda: np.zeros((0, 4, 4)))

    @property
    def symmetric(self) -> bool:
        """Whether a non-identity rotation maps the model onto itself (then ADD-S judges its poses)."""
        return len(self.symmetries) > 0


def axis_rotation(axis: int, angle_deg: float) -> np.ndarray:
    """(3, 3) rotation by `angle_deg` [deg] about object axis `axis` (0, 1, 2: x, y, z)."""
    a = np.radians(angle_deg)
    c, s = np.cos(a), np.sin(a)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    rot = np.eye(3)
    rot[i, i], rot[i, j], rot[j, i], rot[j, j] = c, -s, s, c
    return rot


def probe_rotations() -> np.ndarray:
    """(9, 3, 3) rotations tried as symmetries: 90, 180 and 37 degrees about x, y and z."""
    return np.array([axis_rotation(axis, angle) for axis in range(3) for angle in _PROBE_ANGLES_DEG])


def find_symmetries(points: np.ndarray, tolerance: float = SYMMETRY_TOLERANCE, probes: int = 800) -> np.ndarray:
    """(k, 3, 3) probe rotations R that move every point of (n, 3) `points` [m] to within `tolerance` [m]
    of another (checked on `probes` evenly spaced points, since R maps a finite sample into itself)."""
    query = points[np.linspace(0, len(points) - 1, min(probes, len(points))).astype(int)]
    found = []
    for rot in probe_rotations():
        if nearest_distances(query @ rot.T, points).max() < tolerance:
            found.append(rot)
    return np.array(found).reshape(-1, 3, 3)


def find_near_symmetries(points: np.ndarray, normals: np.ndarray, voxel: float,
                         min_fitness: float = NEAR_SYMMETRY_FITNESS, tolerance: float = SYMMETRY_TOLERANCE,
                         step_deg: float = NEAR_SYMMETRY_STEP_DEG, probes: int = 400) -> np.ndarray:
    """(j, 4, 4) near-symmetries of the model sampled by `points` (n, 3) [m] with outward `normals` (n, 3).

    From every rotation by a multiple of `step_deg` about each object axis, point-to-plane ICP
    (`refine_icp` at `voxel` [m]) moves `probes` evenly spaced samples onto the model's surface; the
    result S is kept if it puts at least `min_fitness` of them within a voxel of a sample while some
    lands farther than `tolerance` [m] from every sample (else S is a symmetry, or the identity, where
    ICP takes a small turn back to). Near-duplicates (within 10 deg and 1 cm of a kept S) are dropped.
    """
    params = RegistrationParams(voxel=voxel)
    query = points[np.linspace(0, len(points) - 1, min(probes, len(points))).astype(int)]
    found: list[np.ndarray] = []
    for axis in range(3):
        for angle in np.arange(step_deg, 360.0 - step_deg / 2, step_deg):
            start = np.eye(4)
            start[:3, :3] = axis_rotation(axis, float(angle))
            reg = refine_icp(query, points, normals, start, params)
            s = reg.transform
            if reg.fitness < min_fitness:
                continue
            moved = o3d_cloud(query @ s[:3, :3].T + s[:3, 3])
            if np.max(moved.compute_point_cloud_distance(o3d_cloud(points))) < tolerance:
                continue
            if any(shift < 0.01 and turn < 10.0 for shift, turn in (pose_distance(s, k) for k in found)):
                continue
            found.append(s)
    return np.array(found).reshape(-1, 4, 4)


def build_model(asset: ObjectAsset, params: FeatureParams | None = None, seed: int = 0) -> Model:
    """Sample `asset`'s visual mesh and compute its features and symmetries (deterministic for `seed`)."""
    params = params or FeatureParams()
    mesh = trimesh.load(str(asset.visual_path), force="mesh", process=False)
    samples, faces = trimesh.sample.sample_surface_even(mesh, SAMPLES, seed=seed)
    normals = mesh.face_normals[faces]
    points, point_normals = downsample(samples, normals, params.voxel, average=False)
    dense, dense_normals = downsample(samples, normals, params.voxel / 2, average=False)
    hull = mesh.convex_hull.vertices
    diameter = float(np.max(np.linalg.norm(hull[:, None] - hull[None], axis=2)))
    return Model(asset.name, points, point_normals, fpfh(points, point_normals, params), dense, dense_normals,
                 find_symmetries(points), diameter, find_near_symmetries(points, point_normals, params.voxel))


class ModelDatabase:
    """Name -> `Model` for a set of objects, all with the same feature parameters."""

    def __init__(self, models: Iterable[Model], params: FeatureParams) -> None:
        self.params = params
        self._models = MappingProxyType({m.name: m for m in models})

    @classmethod
    def from_assets(cls, assets: Iterable[ObjectAsset], params: FeatureParams | None = None) -> ModelDatabase:
        """Build a model per asset (default feature parameters if `params` is None)."""
        params = params or FeatureParams()
        return cls([build_model(a, params) for a in assets], params)

    @property
    def models(self) -> Mapping[str, Model]:
        """Read-only name -> model mapping."""
        return self._models

    def names(self) -> tuple[str, ...]:
        """Model names, in insertion order."""
        return tuple(self._models)

    def get(self, name: str) -> Model:
        """The model called `name`; an unknown name lists the available ones."""
        if name not in self._models:
            raise UnknownNameError(f"no model {name!r} in the database; available: {', '.join(self._models)}")
        return self._models[name]
