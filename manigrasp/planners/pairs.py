"""Antipodal contact pairs (`Pairs`): the inward rays they are searched along (`cone_rays`), the search on a
mesh (`find_pairs`, `fingers_reach`) and their thinning (`thin_pairs`).

Shared by the antipodal planner's mesh path (`antipodal`) and point-cloud path (`cloud`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh

from manigrasp.geometry import perpendicular_basis
from manigrasp.planners.geometry import SmoothNormals, barycentric_of, first_hits
from manigrasp.planners.nms import first_nonzero_sign

RAY_OFFSET = 1e-5  # [m], rays start this far along their direction (no self-hit)


@dataclass(frozen=True)
class Pairs:
    """m antipodal contact pairs: contact 1 (finger 1) at `p`, contact 2 at `q`, line `axis` from p to q.

    Attributes:
        p, q: (m, 3) contact points [m]; n_p, n_q: (m, 3) outward unit normals there.
        axis: (m, 3) unit vectors from p to q; width: (m,) |q - p| [m].
        alpha: (m,) the larger angle between the line and an inward normal [rad].
    """

    p: np.ndarray
    q: np.ndarray
    n_p: np.ndarray
    n_q: np.ndarray
    axis: np.ndarray
    width: np.ndarray
    alpha: np.ndarray

    def take(self, keep: np.ndarray) -> Pairs:
        """The pairs selected by a mask or index array."""
        return Pairs(*(getattr(self, f)[keep] for f in ("p", "q", "n_p", "n_q", "axis", "width", "alpha")))

    def __len__(self) -> int:
        return len(self.width)


def cone_rays(axes: np.ndarray, count: int, half_angle: float, rng: np.random.Generator) -> np.ndarray:
    """(n, count, 3) unit rays per axis (n, 3): the axis itself, then count - 1 uniform inside `half_angle`."""
    n = len(axes)
    cos_t = 1.0 - rng.random((n, count)) * (1.0 - np.cos(half_angle))
    cos_t[:, 0] = 1.0
    phi = rng.random((n, count)) * 2.0 * np.pi
    sin_t = np.sqrt(np.clip(1.0 - cos_t**2, 0.0, None))
    a, b = perpendicular_basis(axes)
    return (cos_t[..., None] * axes[:, None] + sin_t[..., None] * (np.cos(phi)[..., None] * a[:, None]
                                                                   + np.sin(phi)[..., None] * b[:, None]))


def find_pairs(mesh: trimesh.Trimesh, normals: SmoothNormals, points: np.ndarray, n_out: np.ndarray,
               rays: np.ndarray, half_angle: float, widths: tuple[float, float], reach: float) -> Pairs:
    """Antipodal pairs from surface points (m, 3) with outward normals (m, 3) and inward rays (m, 3).

    Args:
        half_angle: friction cone half-angle atan(mu) [rad].
        widths: (min, max) jaw width [m].
        reach: half the open jaw width [m]: the line must be free this far from the pair's midpoint.
    """
    faces, dist = first_hits(mesh, points + RAY_OFFSET * rays, rays)
    hit = faces >= 0
    q = points + (RAY_OFFSET + np.where(hit, dist, 0.0))[:, None] * rays
    bary = barycentric_of(mesh, np.where(hit, faces, 0), q)
    n_q = normals.at(np.where(hit, faces, 0), bary)
    cos_p = -np.einsum("ij,ij->i", rays, n_out)
    cos_q = np.einsum("ij,ij->i", rays, n_q)
    width = np.linalg.norm(q - points, axis=1)
    cos_max = np.cos(half_angle)
    keep = hit & (cos_p >= cos_max) & (cos_q >= cos_max) & (width >= widths[0]) & (width <= widths[1])
    pairs = Pairs(p=points, q=q, n_p=n_out, n_q=n_q, axis=rays, width=width,
                  alpha=np.arccos(np.clip(np.minimum(cos_p, cos_q), -1.0, 1.0))).take(keep)
    return pairs.take(fingers_reach(mesh, pairs, reach))


def thin_pairs(pairs: Pairs, cell: float, axis_bins: int = 6) -> np.ndarray:
    """Indices of the most antipodal pair in each cell of (midpoint on a `cell` [m] grid, grasp line direction).

    The line direction's sign is ignored (p->q and q->p are one line) and each
    component is binned to 1 / `axis_bins` (about 10 degrees for 6). Pairs far
    finer than the NMS thresholds would yield the same poses over and over.
    """
    if len(pairs) == 0:
        return np.zeros(0, int)
    axis = pairs.axis * np.where(first_nonzero_sign(pairs.axis) < 0, -1.0, 1.0)[:, None]
    keys = np.concatenate([np.floor(0.5 * (pairs.p + pairs.q) / cell), np.round(axis * axis_bins)], axis=1)
    order = np.argsort(pairs.alpha, kind="stable")
    _, first = np.unique(keys[order].astype(np.int64), axis=0, return_index=True)
    return np.sort(order[first])


def fingers_reach(mesh: trimesh.Trimesh, pairs: Pairs, reach: float) -> np.ndarray:
    """(m,) True where the grasp line is free of the object beyond both contacts up to the open fingers."""
    beyond = reach - 0.5 * pairs.width  # [m] from each contact out to its open finger
    _, out_q = first_hits(mesh, pairs.q + RAY_OFFSET * pairs.axis, pairs.axis)
    _, out_p = first_hits(mesh, pairs.p - RAY_OFFSET * pairs.axis, -pairs.axis)
    return (out_q > beyond) & (out_p > beyond)
