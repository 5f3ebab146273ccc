"""Pose estimation of a known model in an observed cloud, and recognition of which model it is.

`estimate_pose` registers the observed cloud onto a model (RANSAC on FPFH
matches, then point-to-plane ICP) from `restarts` seeds and keeps the
hypothesis with the best verification score. `recognize` does that for every
model of a database whose size fits the cloud and names the best one whose
score clears a threshold.

Each model's RANSAC seeds come from its own generator (`model_rng`: the view's
seed and the model's name), so a model's estimate does not depend on which
other models the database holds.

Verification (render and compare): the model's camera-facing samples are
placed at the hypothesis and projected into the depth frame. A sample is
explained where the observed depth agrees with it, contradicted where the
camera sees *through* it (the observed surface lies behind it) or where it
sinks into the table; a sample behind an observed surface is occluded and
counts neither way. `coverage` = explained / (explained + contradicted);
`score` = fitness x coverage, where fitness is the fraction of observed
points the model explains. Fitness alone would let a large box "explain"
every view of a small one; coverage rejects it.
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass

import numpy as np

from manigrasp.errors import ConfigError
from manigrasp.perception.camera import DepthImage
from manigrasp.perception.cloud import Cloud
from manigrasp.perception.features import downsample, fpfh
from manigrasp.perception.models import Model, ModelDatabase
from manigrasp.perception.registration import RegistrationParams, register


@dataclass(frozen=True)
class PoseEstimate:
    """A model's pose hypothesis.

    Attributes:
        name: the model's name.
        pose: (4, 4) estimated object-to-world pose [m].
        fitness: fraction of observed points within the inlier distance of the placed model [0, 1].
        inlier_rmse: RMS distance of those points [m].
        coverage: fraction of the placed model's visible samples the frame does not contradict [0, 1].
        score: fitness x coverage.
    """

    name: str
    pose: np.ndarray
    fitness: float
    inlier_rmse: float
    coverage: float

    @property
    def score(self) -> float:
        """fitness x coverage."""
        return self.fitness * self.coverage


@dataclass(frozen=True)
class Recognition:
    """What `recognize` concluded.

    Attributes:
        best: the best-scoring hypothesis, or None if no model fits the cloud's size.
        recognized: whether `best.score` reached the threshold.
        candidates: every model tried, best first.
    """

    best: PoseEstimate | None
    recognized: bool
    candidates: tuple[PoseEstimate, ...]

    @property
    def name(self) -> str | None:
        """The recognised model's name, or None."""
        return self.best.name if self.recognized and self.best is not None else None


@dataclass(frozen=True)
class ObservedFeatures:
    """The observed cloud down-sampled to the feature voxel, with its FPFH descriptors."""

    points: np.ndarray
    normals: np.ndarray
    features: np.ndarray


def observed_features(cloud: Cloud, database: ModelDatabase) -> ObservedFeatures:
    """Down-sample `cloud` (with normals) to the database's voxel and compute FPFH."""
    points, normals = downsample(cloud.points, cloud.normals, database.params.voxel)
    return ObservedFeatures(points, normals, fpfh(points, normals, database.params))


def coverage(model: Model, pose: np.ndarray, image: DepthImage, tolerance: float, table_height: float = 0.0) -> float:
    """Fraction of `model`'s camera-facing samples at `pose` (4, 4) that `image` does not contradict
    (see the module docstring); `tolerance` [m] is the depth agreement. 0 if none can be judged."""
    cam, k = image.camera, image.camera.intrinsics
    world = model.points @ pose[:3, :3].T + pose[:3, 3]
    normals = model.normals @ pose[:3, :3].T
    facing = np.einsum("ij,ij->i", normals, cam.position - world) > 0
    below = world[:, 2] < table_height - tolerance
    local = (world - cam.pose[:3, 3]) @ cam.pose[:3, :3]
    z = local[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        u = np.floor(k.fx * local[:, 0] / z + k.cx).astype(int)
        v = np.floor(k.fy * local[:, 1] / z + k.cy).astype(int)
    inside = facing & (z > 0) & (u >= 0) & (u < k.width) & (v >= 0) & (v < k.height)
    observed = np.full(len(world), np.nan)
    observed[inside] = image.depth[v[inside], u[inside]]
    judged = inside & np.isfinite(observed)
    explained = judged & (np.abs(observed - z) <= tolerance)
    contradicted = (judged & (observed > z + tolerance)) | (below & facing)
    total = int(explained.sum() + contradicted.sum())
    return float(explained.sum()) / total if total else 0.0


def model_rng(seed: int, name: str) -> np.random.Generator:
    """The generator of model `name`'s RANSAC seeds, from (`seed`, crc32(`name`)): a model's estimate
    depends on the seed and the view, not on which other models the database holds."""
    return np.random.default_rng([int(seed), zlib.crc32(name.encode())])


def draw_seed(rng: np.random.Generator) -> int:
    """One seed for `model_rng`, drawn from `rng` (the view's generator)."""
    return int(rng.integers(0, 2**63 - 1))


def estimate_pose(model: Model, observed: ObservedFeatures, image: DepthImage, params: RegistrationParams,
                  rng: np.random.Generator, restarts: int = 4, table_height: float = 0.0,
                  good_score: float = 0.95) -> PoseEstimate:
    """The best of up to `restarts` (>= 1) RANSAC + ICP hypotheses of `model` in the observed cloud (by
    `score`); it stops at the first hypothesis scoring `good_score` or more. `rng` draws the RANSAC seeds
    (`model_rng` gives each model its own)."""
    if restarts < 1:
        raise ConfigError(f"restarts must be >= 1, got {restarts}")
    best: PoseEstimate | None = None
    tolerance = 2.0 * params.voxel
    for seed in rng.integers(0, 2**31 - 1, size=restarts):
        reg = register(observed.points, observed.features, model.points, model.features, model.normals, params,
                       int(seed), icp_target=(model.dense_points, model.dense_normals))
        pose = np.linalg.inv(reg.transform)
        hypothesis = PoseEstimate(model.name, pose, reg.fitness, reg.inlier_rmse,
                                  coverage(model, pose, image, tolerance, table_height))
        if best is None or (hypothesis.score, -hypothesis.inlier_rmse) > (best.score, -best.inlier_rmse):
            best = hypothesis
        if best.score >= good_score:
            break
    return best  # type: ignore[return-value]  # restarts >= 1


def diameter(points: np.ndarray, max_points: int = 1500) -> float:
    """Largest distance [m] between two of (n, 3) `points` (at most `max_points` evenly spaced ones)."""
    pts = points[np.linspace(0, len(points) - 1, min(max_points, len(points))).astype(int)]
    sq = np.einsum("ij,ij->i", pts, pts)
    return float(np.sqrt(max((sq[:, None] - 2 * pts @ pts.T + sq[None, :]).max(), 0.0)))


def fits_size(model: Model, observed: ObservedFeatures, slack: float = 0.01) -> bool:
    """Whether the observed points could lie on `model`: their diameter does not exceed the model's + `slack` [m]."""
    return diameter(observed.points) <= model.diameter + slack


def recognize(database: ModelDatabase, cloud: Cloud, image: DepthImage, params: RegistrationParams,
              rng: np.random.Generator, threshold: float = 0.7, restarts: int = 2,
              table_height: float = 0.0) -> Recognition:
    """Which model of `database` the cloud shows: the best `score` over the models whose size fits,
    recognised if it reaches `threshold`. One seed is drawn from `rng`; each model's RANSAC draws from
    its own `model_rng(seed, name)`, so a model's estimate is the same whatever else the database holds
    (and the same as `estimate_pose` with that generator)."""
    observed = observed_features(cloud, database)
    seed = draw_seed(rng)
    candidates = [estimate_pose(m, observed, image, params, model_rng(seed, m.name), restarts, table_height)
                  for m in database.models.values() if fits_size(m, observed)]
    candidates.sort(key=lambda e: -e.score)
    best = candidates[0] if candidates else None
    return Recognition(best, best is not None and best.score >= threshold, tuple(candidates))
