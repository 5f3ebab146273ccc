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
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np
import trimesh

from manigrasp.errors import UnknownNameError
from manigrasp.objects.asset import ObjectAsset
from manigrasp.perception.features import FeatureParams, downsample, fpfh
from manigrasp.perception.metrics import nearest_distances

SYMMETRY_TOLERANCE = 0.006  # [m] Hausdorff distance below which a rotation maps the model onto itself
SAMPLES = 30_000  # surface samples per model before down-sampling
_PROBE_ANGLES_DEG = (90.0, 180.0, 37.0)


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
    """

    name: str
    points: np.ndarray
    normals: np.ndarray
    features: np.ndarray
    dense_points: np.ndarray
    dense_normals: np.ndarray
    symmetries: np.ndarray
    diameter: float

    @property
    def symmetric(self) -> bool:
        """Whether a non-identity rotation maps the model onto itself (then ADD-S judges its poses)."""
        return len(self.symmetries) > 0


def _axis_rotation(axis: int, angle_deg: float) -> np.ndarray:
    a = np.radians(angle_deg)
    c, s = np.cos(a), np.sin(a)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    rot = np.eye(3)
    rot[i, i], rot[i, j], rot[j, i], rot[j, j] = c, -s, s, c
    return rot


def probe_rotations() -> np.ndarray:
    """(9, 3, 3) rotations tried as symmetries: 90, 180 and 37 degrees about x, y and z."""
    return np.array([_axis_rotation(axis, angle) for axis in range(3) for angle in _PROBE_ANGLES_DEG])


def find_symmetries(points: np.ndarray, tolerance: float = SYMMETRY_TOLERANCE, probes: int = 800) -> np.ndarray:
    """(k, 3, 3) probe rotations R that move every point of (n, 3) `points` [m] to within `tolerance` [m]
    of another (checked on `probes` evenly spaced points, since R maps a finite sample into itself)."""
    query = points[np.linspace(0, len(points) - 1, min(probes, len(points))).astype(int)]
    found = []
    for rot in probe_rotations():
        if nearest_distances(query @ rot.T, points).max() < tolerance:
            found.append(rot)
    return np.array(found).reshape(-1, 3, 3)


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
                 find_symmetries(points), diameter)


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
