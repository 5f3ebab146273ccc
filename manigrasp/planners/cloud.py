"""Antipodal pairs on a point cloud: denoising, symmetric completion, ray neighbours (scipy cKDTree).

Input: a single view of the object, `points` (n, 3) in the world [m] with
outward unit `normals` (n, 3) (estimated, oriented toward the camera), the
table removed.

1. Denoise: each point is projected onto the plane through the centroid of
   its `k` nearest neighbours with its normal (~1 mm of depth noise becomes
   ~0.3 mm).
2. Complete (`completion="point_symmetry"`): one view sees the front of an
   object, seldom the opposite face a second finger needs. The cloud is
   reflected through an estimated centre c (x' = 2 c - x, n' = -n), which
   maps every face of a box, a cylinder or a sphere resting on the table to
   its opposite face (the symmetry assumption of Bohg et al., "Mind the
   gap", ICRA 2011, with a point instead of a mirror plane). c: horizontally
   the middle of the extent of the top (the up-facing points, normal
   z > 0.7, within 3 mm of their 90th height percentile; all points if
   fewer than 10 face up), vertically midway between the table and the
   top's mean height. Reflected points below the table are dropped. c is the
   estimated centre of mass; the mass is `density` x the volume of the
   completed cloud's convex hull. With `completion="none"` only observed
   points are used, and c is the centroid of the observed points.
3. Pairs: from each sampled observed point p, the rays of the mesh path
   (`antipodal.cone_rays`). The opposite contact is where the ray leaves
   the completed cloud: the nearest points within `radius` of the ray,
   between the jaw's min and max width, whose normals lie within the
   friction cone of the ray (the first such surface; q = p + t d with t and
   the normal averaged over that surface's points). A point facing back
   toward p before it (the ray left the object unseen) rejects the ray, and
   so does any point on the line beyond either contact up to the open
   fingers (as the mesh path's `fingers_reach`).
4. Collision geometry (`collision_hull`): the convex hull of the completed
   cloud, pushed `margin` outward from c, and the table.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import ConvexHull, cKDTree

from manigrasp.errors import PlannerError
from manigrasp.planners.pairs import Pairs, cone_rays

UP = 0.7  # normal z above which a point faces up (within ~45 degrees of vertical)
MIN_POINTS = 10
TOP_BAND = 0.003  # [m] up-facing points this close below the top height make the top


@dataclass(frozen=True)
class CompletedCloud:
    """An observed cloud, denoised, with its symmetric completion.

    Attributes:
        points: (m, 3) observed then reflected points [m]; normals: (m, 3) outward unit normals.
        observed: number of observed points (the first rows).
        center: (3,) estimated centre (of symmetry and of mass) [m].
        spacing: median distance between neighbouring observed points [m].
    """

    points: np.ndarray
    normals: np.ndarray
    observed: int
    center: np.ndarray
    spacing: float


def unit(vectors: np.ndarray) -> np.ndarray:
    """Rows of `vectors` (n, 3) scaled to unit length (zero rows stay zero)."""
    vectors = np.asarray(vectors, float)
    norm = np.linalg.norm(vectors, axis=1, keepdims=True)
    return np.divide(vectors, norm, out=np.zeros_like(vectors), where=norm > 1e-12)


def denoise(points: np.ndarray, normals: np.ndarray, k: int = 12) -> tuple[np.ndarray, float]:
    """`points` (n, 3) projected on their neighbourhood planes (module docstring, step 1), and the median
    nearest-neighbour spacing [m]."""
    tree = cKDTree(points)
    dist, idx = tree.query(points, k=min(k, len(points)))
    centroid = points[idx].mean(axis=1)
    offset = np.einsum("ij,ij->i", points - centroid, normals)
    spacing = float(np.median(dist[:, 1])) if dist.shape[1] > 1 else 0.0
    return points - offset[:, None] * normals, spacing


def complete(points: np.ndarray, normals: np.ndarray, table_height: float, completion: str) -> CompletedCloud:
    """The denoised cloud and its reflection through the estimated centre (module docstring, step 2)."""
    if len(points) < MIN_POINTS:
        raise PlannerError(f"antipodal needs at least {MIN_POINTS} cloud points, got {len(points)}")
    normals = unit(np.asarray(normals, float))
    clean, spacing = denoise(np.asarray(points, float), normals)
    if completion == "none":
        return CompletedCloud(clean, normals, len(clean), clean.mean(axis=0), spacing)
    center = symmetry_center(clean, normals, table_height, spacing)
    mirrored = 2.0 * center - clean
    keep = mirrored[:, 2] >= table_height
    return CompletedCloud(np.vstack([clean, mirrored[keep]]), np.vstack([normals, -normals[keep]]), len(clean),
                          center, spacing)


def symmetry_center(points: np.ndarray, normals: np.ndarray, table_height: float, spacing: float) -> np.ndarray:
    """(3,) estimated centre of an object resting on the table (module docstring, step 2) [m].

    The top: up-facing points within `TOP_BAND` (or 2 `spacing`) of the 90th percentile of their height;
    the centre lies below the middle of the top's extent in x and y (1st to 99th percentile; a rectangle's
    or a disc's centre), midway between the table and the top.
    """
    up = normals[:, 2] > UP
    if up.sum() < MIN_POINTS:
        up = np.ones(len(points), bool)
    z_top = np.percentile(points[up, 2], 90)
    top = points[up & (points[:, 2] > z_top - max(TOP_BAND, 2.0 * spacing))]
    low, high = np.percentile(top[:, :2], [1, 99], axis=0)
    return np.array([*(0.5 * (low + high)), 0.5 * (table_height + top[:, 2].mean())])


def hull_volume(points: np.ndarray) -> float:
    """Volume [m^3] of the convex hull of `points` (n, 3) (0 if they are flat)."""
    try:
        return float(ConvexHull(points).volume)
    except Exception:  # qhull refuses flat or degenerate sets: no volume
        return 0.0


def collision_hull(cloud: CompletedCloud, margin: float) -> np.ndarray:
    """Vertices (h, 3) [m] of the completed cloud's convex hull, pushed `margin` [m] away from its centre."""
    pushed = cloud.points + margin * unit(cloud.points - cloud.center)
    try:
        return pushed[ConvexHull(pushed).vertices]
    except Exception as exc:  # flat clouds have no hull
        raise PlannerError(f"the point cloud spans no volume ({exc.__class__.__name__})") from exc


@dataclass(frozen=True)
class RayHits:
    """Cloud points near rays: ray index (k,), point index (k,), distance along the ray t (k,) [m]."""

    ray: np.ndarray
    point: np.ndarray
    t: np.ndarray


def near_rays(tree: cKDTree, origins: np.ndarray, directions: np.ndarray, t_min: float, t_max: float,
              radius: float, k: int = 12) -> RayHits:
    """Points within `radius` [m] of each ray (origins, unit directions (r, 3)) with t in [t_min, t_max].

    Balls of radius 1.12 `radius` every `radius` along each ray cover the cylinder; each ball keeps its `k`
    nearest points. Each (ray, point) appears once.
    """
    stations = np.arange(t_min, t_max + radius, radius)
    centres = origins[:, None] + stations[None, :, None] * directions[:, None]  # (r, s, 3)
    _, idx = tree.query(centres.reshape(-1, 3), k=k, distance_upper_bound=1.12 * radius)
    ray = np.repeat(np.arange(len(origins)), len(stations) * k)
    idx = idx.ravel()
    found = idx < tree.n
    ray, idx = ray[found], idx[found]
    key = np.unique(ray.astype(np.int64) * tree.n + idx)
    ray, idx = key // tree.n, key % tree.n
    rel = tree.data[idx] - origins[ray]
    t = np.einsum("ij,ij->i", rel, directions[ray])
    perp = np.linalg.norm(rel - t[:, None] * directions[ray], axis=1)
    keep = (perp <= radius) & (t >= t_min) & (t <= t_max)
    return RayHits(ray[keep], idx[keep], t[keep])


def _first_per_ray(ray: np.ndarray, t: np.ndarray, n_rays: int) -> np.ndarray:
    """(n_rays,) smallest t per ray (inf where none)."""
    out = np.full(n_rays, np.inf)
    np.minimum.at(out, ray, t)
    return out


def exits(cloud: CompletedCloud, tree: cKDTree, p: np.ndarray, d: np.ndarray, cos_max: float,
          widths: tuple[float, float], reach: float, radius: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where rays from p along d (r, 3) leave the cloud (module docstring, step 3).

    Returns:
        width t (r,) [m] (nan where rejected), the outward normal there (r, 3), and the cosine between the
        ray and that normal (r,).
    """
    n_rays = len(p)
    beyond_max = max(reach - 0.5 * widths[0], radius)
    hits = near_rays(tree, p, d, -beyond_max, widths[1] + beyond_max, radius)
    facing = np.einsum("ij,ij->i", cloud.normals[hits.point], d[hits.ray])
    inside = (hits.t >= widths[0]) & (hits.t <= widths[1])
    leave = inside & (facing >= cos_max)
    t_first = _first_per_ray(hits.ray[leave], hits.t[leave], n_rays)
    cluster = leave & (hits.t <= t_first[hits.ray] + radius)
    count = np.bincount(hits.ray[cluster], minlength=n_rays)
    t_mean = np.bincount(hits.ray[cluster], hits.t[cluster], minlength=n_rays) / np.maximum(count, 1)
    normal = np.stack([np.bincount(hits.ray[cluster], cloud.normals[hits.point[cluster], j], minlength=n_rays)
                       for j in range(3)], axis=1)
    normal = unit(normal)
    # Rejections: a surface facing back toward p before the exit; anything on the line beyond the contacts.
    back = (facing < 0) & (hits.t > radius) & (hits.t < t_first[hits.ray] - radius)
    beyond = reach - 0.5 * t_mean[hits.ray]
    outside = ((hits.t < -radius) & (hits.t > -beyond)) | ((hits.t > t_first[hits.ray] + 2 * radius)
                                                          & (hits.t < t_mean[hits.ray] + beyond))
    blocked = np.zeros(n_rays, bool)
    blocked[hits.ray[back | (outside & np.isfinite(t_first[hits.ray]))]] = True
    ok = (count > 0) & ~blocked
    cos_q = np.einsum("ij,ij->i", normal, d)
    return np.where(ok, t_mean, np.nan), normal, cos_q


def cloud_pairs(cloud: CompletedCloud, n_samples: int, rays_per_sample: int, ray_cone: float, mu: float,
                widths: tuple[float, float], reach: float, radius: float, rng: np.random.Generator) -> Pairs:
    """Antipodal pairs from `n_samples` observed points of `cloud` (module docstring, step 3).

    Args:
        rays_per_sample, ray_cone: as the mesh path (`antipodal.AntipodalPlanner`).
        mu: friction coefficient (cone half-angle atan(mu)).
        widths: (min, max) jaw width [m]; reach: half the open jaw width [m].
        radius: how far from a ray a point may lie and still be on it [m].
    """
    half_angle = float(np.arctan(mu))
    chosen = rng.choice(cloud.observed, size=min(n_samples, cloud.observed), replace=False)
    n_out = cloud.normals[chosen]
    rays = cone_rays(-n_out, rays_per_sample, ray_cone * half_angle, rng).reshape(-1, 3)
    p = np.repeat(cloud.points[chosen], rays_per_sample, axis=0)
    n_p = np.repeat(n_out, rays_per_sample, axis=0)
    cos_max = float(np.cos(half_angle))
    width, n_q, cos_q = exits(cloud, cKDTree(cloud.points), p, rays, cos_max, widths, reach, radius)
    cos_p = -np.einsum("ij,ij->i", rays, n_p)
    keep = np.isfinite(width) & (cos_p >= cos_max) & (cos_q >= cos_max)
    width = np.where(keep, width, 0.0)
    pairs = Pairs(p=p, q=p + width[:, None] * rays, n_p=n_p, n_q=n_q, axis=rays, width=width,
                  alpha=np.arccos(np.clip(np.minimum(cos_p, cos_q), -1.0, 1.0)))
    return pairs.take(keep)
