"""Vectorised geometry for the planners: surface samples, smooth normals, ray hits, frames
(rotations and poses: `manigrasp.geometry`).

Pure NumPy (and trimesh's ray casting, with embree where installed). Every
random draw comes from an explicit `numpy.random.Generator`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh

from manigrasp.geometry import quat_to_mat

CREASE_ANGLE = np.radians(20.0)
"""Faces meeting at a sharper angle than this keep separate normals (a box's edges)."""


@dataclass(frozen=True)
class SurfaceSamples:
    """Points on a mesh surface.

    Attributes:
        points: (n, 3) [m].
        faces: (n,) index of the face each point lies on.
        barycentric: (n, 3) barycentric coordinates on that face.
    """

    points: np.ndarray
    faces: np.ndarray
    barycentric: np.ndarray


def sample_surface(mesh: trimesh.Trimesh, n: int, rng: np.random.Generator) -> SurfaceSamples:
    """`n` points uniformly distributed over the surface area of `mesh`."""
    areas = np.asarray(mesh.area_faces, float)
    faces = rng.choice(len(areas), size=n, p=areas / areas.sum())
    u, v = rng.random(n), rng.random(n)
    flip = u + v > 1.0
    u, v = np.where(flip, 1.0 - u, u), np.where(flip, 1.0 - v, v)
    bary = np.stack([1.0 - u - v, u, v], axis=1)
    points = np.einsum("nk,nkj->nj", bary, mesh.triangles[faces])
    return SurfaceSamples(points=points, faces=faces, barycentric=bary)


class SmoothNormals:
    """Outward normals interpolated over each face from its corners, with creases kept sharp.

    A corner's normal averages the faces around its vertex that are smoothly
    connected (angle below `CREASE_ANGLE`); large flat facets keep their face
    normal. On a sphere the interpolated normal at a point is radial, on a box
    it is the face normal, so an inward ray along it is the ideal grasp line.
    """

    def __init__(self, mesh: trimesh.Trimesh) -> None:
        smooth = trimesh.graph.smooth_shade(mesh, angle=CREASE_ANGLE)
        components = smooth.metadata.get("original_components")
        corners = np.repeat(np.asarray(mesh.face_normals, float)[:, None, :], 3, axis=1)
        if components is not None and len(smooth.faces) == len(mesh.faces):
            original = np.hstack(components).astype(int)
            corners[original] = np.asarray(smooth.vertex_normals, float)[smooth.faces]
        self.corners = corners  # (F, 3, 3): normal at each corner of each face
        self.face_normals = np.asarray(mesh.face_normals, float)

    def at(self, faces: np.ndarray, barycentric: np.ndarray) -> np.ndarray:
        """(n, 3) unit normals at points given by face index (n,) and barycentric coordinates (n, 3)."""
        normals = np.einsum("nk,nkj->nj", barycentric, self.corners[faces])
        length = np.linalg.norm(normals, axis=1, keepdims=True)
        fallback = self.face_normals[faces]
        return np.where(length > 1e-9, normals / np.maximum(length, 1e-12), fallback)


def barycentric_of(mesh: trimesh.Trimesh, faces: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(n, 3) barycentric coordinates of `points` (n, 3) on faces `faces` (n,)."""
    return trimesh.triangles.points_to_barycentric(mesh.triangles[faces], points)


def first_hits(mesh: trimesh.Trimesh, origins: np.ndarray, directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """First face hit by each ray and the distance to it, in float64.

    Args:
        origins: (n, 3) [m]; directions: (n, 3) unit vectors.

    Returns:
        faces (n,) (-1 for a miss) and distances (n,) [m] (inf for a miss).
    """
    if len(origins) == 0:
        return np.zeros(0, int), np.zeros(0)
    faces = np.asarray(mesh.ray.intersects_first(ray_origins=origins, ray_directions=directions), int)
    dist = np.full(len(origins), np.inf)
    hit = faces >= 0
    # Recompute the distance to the hit face's plane in float64 (embree works in float32).
    normal = np.asarray(mesh.face_normals, float)[faces[hit]]
    v0 = mesh.triangles[faces[hit], 0]
    denom = np.einsum("ij,ij->i", directions[hit], normal)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.einsum("ij,ij->i", v0 - origins[hit], normal) / denom
    dist[hit] = np.where(np.isfinite(t) & (t >= 0), t, np.inf)
    faces[hit & ~np.isfinite(dist)] = -1
    return faces, dist


def tcp_frames(positions: np.ndarray, approach: np.ndarray, closing: np.ndarray) -> np.ndarray:
    """(n, 4, 4) TCP poses: z = `approach`, y = `closing` (orthogonalised against z), x = y cross z."""
    z = approach / np.linalg.norm(approach, axis=1, keepdims=True)
    y = closing - np.einsum("ij,ij->i", closing, z)[:, None] * z
    y /= np.linalg.norm(y, axis=1, keepdims=True)
    poses = np.zeros((len(z), 4, 4))
    poses[:, :3, 0], poses[:, :3, 1], poses[:, :3, 2] = np.cross(y, z), y, z
    poses[:, :3, 3], poses[:, 3, 3] = positions, 1.0
    return poses


def fibonacci_sphere(n: int) -> np.ndarray:
    """(n, 3) nearly uniform unit vectors (the Fibonacci lattice), deterministic."""
    i = np.arange(n) + 0.5
    z = 1.0 - 2.0 * i / n
    phi = np.pi * (1.0 + 5.0**0.5) * i
    r = np.sqrt(1.0 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def random_rotations(n: int, rng: np.random.Generator) -> np.ndarray:
    """(n, 3, 3) rotations uniform on SO(3) (from uniform unit quaternions)."""
    return quat_to_mat(rng.normal(size=(n, 4)))
