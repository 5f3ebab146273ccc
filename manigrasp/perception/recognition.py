"""Pose estimation of a known model in an observed cloud, and recognition of which model it is.

`estimate_pose` registers the observed cloud onto a model (RANSAC on FPFH
matches, then point-to-plane ICP) from `restarts` seeds and keeps the
hypothesis with the best verification score. `recognize` does that for every
model of a database whose size fits the cloud and names the best one whose
score clears a threshold.

Near-symmetric models (a mug): RANSAC gets the part of the pose that the
symmetric part fixes and leaves the rest to chance. FPFH
matches of a mug's body are alike at every angle about its axis (about 1 % of
the matches of a noisy view lie within RANSAC's inlier distance of the truth),
so a sample of three right matches is rare in 20 000 iterations, while samples
consistent with the body turned about its axis, or upside down, are common;
the returned fit explains 90-100 % of the observed points at a turn that is
chance, and ICP does not bring a handle back from more than about 10 deg.
Each RANSAC + ICP hypothesis is therefore also tried composed with each of the
model's near-symmetries (`manigrasp.perception.models.find_near_symmetries`),
each refined by ICP, and the best by verification is then refined by a
pattern search (ICP from small turns and shifts of it, kept when verification
scores them higher): ICP also settles a few degrees off the handle, and a box
seen on two faces slides 2-4 cm along them (fitness 0.87, score 0.4).
Verification sees the handle: a pose that puts it where the camera sees it
explains its points, one that puts it where the camera sees through it is
contradicted (0.99-1.0 against 0.75-0.97 on the mug).

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
from manigrasp.perception.models import Model, ModelDatabase, axis_rotation
from manigrasp.perception.registration import Registration, RegistrationParams, refine_icp, register


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


def _verify(model: Model, reg: Registration, image: DepthImage, tolerance: float,
            table_height: float) -> PoseEstimate:
    pose = np.linalg.inv(reg.transform)
    return PoseEstimate(model.name, pose, reg.fitness, reg.inlier_rmse,
                        coverage(model, pose, image, tolerance, table_height))


def _better(a: PoseEstimate, b: PoseEstimate | None) -> bool:
    return b is None or (a.score, -a.inlier_rmse) > (b.score, -b.inlier_rmse)


def _moves(angle_deg: float, shift: float) -> list[np.ndarray]:
    """(4, 4) turns by +-`angle_deg` [deg] about, and shifts by +-`shift` [m] along, each object axis."""
    moves = []
    for axis in range(3):
        for sign in (1.0, -1.0):
            turn = np.eye(4)
            turn[:3, :3] = axis_rotation(axis, sign * angle_deg)
            move = np.eye(4)
            move[axis, 3] = sign * shift
            moves += [turn, move]
    return moves


def refine_pose(model: Model, observed: ObservedFeatures, image: DepthImage, params: RegistrationParams,
                estimate: PoseEstimate, table_height: float = 0.0, good_score: float = 0.98,
                steps: tuple[tuple[float, float], ...] = ((10.0, 0.02), (5.0, 0.01)),
                rounds: int = 3) -> PoseEstimate:
    """`estimate` of `model` refined by a pattern search on the verification score, if it scores below
    `good_score`: ICP from it turned by +-angle [deg] about, and shifted by +-shift [m] along, each object
    axis, a better-scoring result replacing it, for up to `rounds` rounds per (angle, shift) of `steps`
    (coarse to fine). ICP settles in a wrong minimum a few degrees off when a few points (a handle's) fix a
    turn, and a box seen on two faces slides along them; the score sees both (0.88-0.97 against 0.99-1.0
    at the truth on the mug; right poses of the benchmark's objects score 0.99-1.0)."""
    tolerance = 2.0 * params.voxel
    top = estimate
    for angle, shift in steps:
        for _ in range(rounds):
            if top.score >= good_score:
                return top
            improved = False
            start = np.linalg.inv(top.pose)
            for move in _moves(angle, shift):
                candidate = refine_icp(observed.points, model.dense_points, model.dense_normals,
                                       np.linalg.inv(move) @ start, params)
                hypothesis = _verify(model, candidate, image, tolerance, table_height)
                if _better(hypothesis, top):
                    top, improved = hypothesis, True
            if not improved:
                break
    return top


def estimate_pose(model: Model, observed: ObservedFeatures, image: DepthImage, params: RegistrationParams,
                  rng: np.random.Generator, restarts: int = 4, table_height: float = 0.0,
                  good_score: float = 0.98, refine: bool = True) -> PoseEstimate:
    """The best (by `score`) of up to `restarts` (>= 1) RANSAC + ICP hypotheses of `model` in the observed
    cloud; `rng` draws the RANSAC seeds (`model_rng` gives each model its own).

    Each restart's hypothesis is also tried composed with every near-symmetry of the model, each refined
    by ICP (module docstring), and the best of them, with `refine`, by `refine_pose`. It stops after the
    first restart whose best reaches `good_score`.
    """
    if restarts < 1:
        raise ConfigError(f"restarts must be >= 1, got {restarts}")
    best: PoseEstimate | None = None
    tolerance = 2.0 * params.voxel
    for seed in rng.integers(0, 2**31 - 1, size=restarts):
        reg = register(observed.points, observed.features, model.points, model.features, model.normals, params,
                       int(seed), icp_target=(model.dense_points, model.dense_normals))
        candidates = [reg] + [refine_icp(observed.points, model.dense_points, model.dense_normals,
                                         np.linalg.inv(near) @ reg.transform, params)  # the pose inv(T) @ near
                              for near in model.near_symmetries]
        top: PoseEstimate | None = None
        for candidate in candidates:
            hypothesis = _verify(model, candidate, image, tolerance, table_height)
            if _better(hypothesis, top):
                top = hypothesis
        if refine:
            top = refine_pose(model, observed, image, params, top, table_height, good_score)  # type: ignore[arg-type]
        if _better(top, best):  # type: ignore[arg-type]  # set above
            best = top
        if best.score >= good_score:  # type: ignore[union-attr]  # set above
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
              table_height: float = 0.0, refine_top: int = 1) -> Recognition:
    """Which model of `database` the cloud shows: the best `score` over the models whose size fits,
    recognised if it reaches `threshold`. Every such model is estimated without `refine_pose` (up to 72
    ICP runs per restart on a model that does not fit), then the `refine_top` best-scoring of them again
    with it, from the same seeds, their refined estimates replacing the first ones (the estimator before
    near-symmetries, which never refined, picked every shipped object right in tests/test_perception_pose.py;
    refining the 3 best made that test 6 times slower).

    One seed is drawn from `rng`; each model's RANSAC draws from its own `model_rng(seed, name)`, so a
    refined model's estimate is the same whatever else the database holds, and the same as
    `estimate_pose` of that model alone with that generator.
    """
    observed = observed_features(cloud, database)
    seed = draw_seed(rng)
    candidates = [estimate_pose(m, observed, image, params, model_rng(seed, m.name), restarts, table_height,
                                refine=False)
                  for m in database.models.values() if fits_size(m, observed)]
    candidates.sort(key=lambda e: -e.score)
    candidates[:refine_top] = [estimate_pose(database.get(e.name), observed, image, params,
                                             model_rng(seed, e.name), restarts, table_height)
                               for e in candidates[:refine_top]]
    candidates.sort(key=lambda e: -e.score)
    best = candidates[0] if candidates else None
    return Recognition(best, best is not None and best.score >= threshold, tuple(candidates))
