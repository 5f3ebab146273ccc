"""Pseudo-scans: a clean mesh re-made the way a real object scan comes out.

A real YCB scan (``assets/scans/``) is a surface reconstructed from noisy depth measurements: about 8k
vertices and 16k faces, millimetre bumps (its vertices lie 0.3-1 mm from a 5-step Laplacian smoothing of
themselves, median), edges rounded by the reconstruction, and sometimes open seams. `pseudo_scan` makes such
a mesh from any watertight mesh, to check on many shapes that a result obtained on clean recipe meshes
transfers to scanned ones (``benchmarks/bench_pseudo_scans.py``):

1. sample `n_points` points uniformly on the surface (seeded);
2. leave out the underside the scanner does not see well: each point whose face looks down (normal z below
   -0.7) within `underside_height_m` of the lowest point is kept only with probability 1 - `underside_drop`;
3. blur the points (`blur_m`: the scanner's resolution, which rounds edges), then move each point along its
   surface normal by Gaussian noise of standard deviation `noise_m` (seeded);
4. estimate normals from the noisy points (`normal_k` nearest neighbours), oriented like the true normals
   (a scanner knows which way it looked);
5. screened Poisson reconstruction (Open3D, octree `depth`, one thread so that it is deterministic), then the
   vertices whose point density is below the `density_quantile` quantile are cut away (the surface Poisson
   invents where there were no points: this leaves holes on a sparsely seen underside);
6. quadric decimation to `target_faces` faces.

The result keeps the source's frame (no re-centring) and is not necessarily watertight; manigrasp's build
pipeline repairs it like a real scan. Needs Open3D (the ``perception`` extra).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
import trimesh


@dataclass(frozen=True)
class PseudoScanParams:
    """Settings of `pseudo_scan` (lengths in metres)."""

    noise_m: float = 0.0007
    """Standard deviation of the Gaussian noise along the surface normal (a YCB scan's bumps: 0.3-1 mm)."""
    n_points: int = 80_000
    """Points sampled on the surface before the underside is thinned."""
    underside_drop: float = 0.5
    """Fraction of the points on the downward-facing surface near the table that the scanner does not see."""
    underside_height_m: float = 0.004
    """Height above the lowest point within which a downward-facing point counts as the underside."""
    blur_m: float = 0.004
    """Radius of the scanner's blur: each sampled point moves to the mean of the points within it whose normals
    are less than 120 deg from its own (edges come out rounded, as a YCB scan's box edges do; the two sides of a
    thin wall are not mixed). 0: no blur."""
    normal_k: int = 30
    """Nearest neighbours of the normal estimate (larger: smoother normals, more rounded edges)."""
    depth: int = 9
    """Octree depth of the Poisson reconstruction (9: cells of about 1/512 of the object's size)."""
    density_quantile: float = 0.01
    """Vertices whose Poisson density is below this quantile are removed (unobserved surface)."""
    target_faces: int = 16_384
    """Faces after decimation (the shipped YCB scans have 16384)."""
    seed: int = 0
    """Seed of the sampling, the underside thinning and the noise."""

    def __post_init__(self) -> None:
        for key in ("noise_m", "underside_height_m", "blur_m"):
            value = getattr(self, key)
            if not (np.isfinite(value) and value >= 0):
                raise ValueError(f"{key} must be a finite number >= 0, got {value!r}")
        for key in ("underside_drop", "density_quantile"):
            value = getattr(self, key)
            if not (0 <= value < 1):
                raise ValueError(f"{key} must be in [0, 1), got {value!r}")
        for key, least in (("n_points", 1000), ("normal_k", 3), ("depth", 5), ("target_faces", 100)):
            if int(getattr(self, key)) < least:
                raise ValueError(f"{key} must be at least {least}, got {getattr(self, key)!r}")

    def as_dict(self) -> dict:
        """The settings as a plain dict."""
        return asdict(self)


def sample_cloud(mesh: trimesh.Trimesh, params: PseudoScanParams) -> tuple[np.ndarray, np.ndarray]:
    """Steps 1-3: the noisy point cloud (n, 3) and its true normals (n, 3)."""
    rng = np.random.default_rng(params.seed)
    # trimesh's sampler takes a seed of its own: derive it from ours so that one seed fixes everything
    points, faces = trimesh.sample.sample_surface(mesh, int(params.n_points), seed=int(rng.integers(2**31)))
    normals = np.asarray(mesh.face_normals)[faces]
    zmin = float(mesh.bounds[0, 2])
    under = (normals[:, 2] < -0.7) & (points[:, 2] < zmin + params.underside_height_m)
    keep = ~under | (rng.random(len(points)) >= params.underside_drop)
    points, normals = points[keep], normals[keep]
    if params.blur_m > 0:
        points = _blur(points, normals, params.blur_m)
    points = points + normals * rng.normal(0.0, params.noise_m, size=(len(points), 1))
    return points, normals


def _blur(points: np.ndarray, normals: np.ndarray, radius: float) -> np.ndarray:
    """Each point replaced by the mean of the points within `radius` whose normal is within 120 deg of its own."""
    from scipy.spatial import cKDTree

    tree = cKDTree(points)
    pairs = tree.query_pairs(radius, output_type="ndarray")
    pairs = pairs[np.einsum("ij,ij->i", normals[pairs[:, 0]], normals[pairs[:, 1]]) > -0.5]
    total = points.copy()
    count = np.ones(len(points))
    np.add.at(total, pairs[:, 0], points[pairs[:, 1]])
    np.add.at(total, pairs[:, 1], points[pairs[:, 0]])
    np.add.at(count, pairs.ravel(), 1.0)
    return total / count[:, None]


def pseudo_scan(mesh: trimesh.Trimesh, params: PseudoScanParams | None = None) -> trimesh.Trimesh:
    """A scan-like reconstruction of the closed mesh `mesh`, in its frame (see the module docstring)."""
    import open3d as o3d

    params = params or PseudoScanParams()
    points, true_normals = sample_cloud(mesh, params)
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    cloud.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(knn=int(params.normal_k)))
    normals = np.asarray(cloud.normals)
    flip = np.einsum("ij,ij->i", normals, true_normals) < 0
    normals[flip] *= -1
    cloud.normals = o3d.utility.Vector3dVector(normals)
    with o3d.utility.VerbosityContextManager(o3d.utility.VerbosityLevel.Error):
        recon, densities = o3d.geometry.TriangleMesh.create_from_point_cloud_poisson(
            cloud, depth=int(params.depth), n_threads=1)
    densities = np.asarray(densities)
    if params.density_quantile > 0:
        recon.remove_vertices_by_mask(densities < np.quantile(densities, params.density_quantile))
    if len(recon.triangles) > params.target_faces:
        recon = recon.simplify_quadric_decimation(target_number_of_triangles=int(params.target_faces))
    recon.remove_degenerate_triangles()
    recon.remove_duplicated_triangles()
    recon.remove_duplicated_vertices()
    recon.remove_unreferenced_vertices()
    out = trimesh.Trimesh(np.asarray(recon.vertices), np.asarray(recon.triangles), process=True)
    # keep the largest connected piece: Poisson may leave small floating blobs where the noise was sparse
    pieces = out.split(only_watertight=False)
    if len(pieces) > 1:
        out = max(pieces, key=lambda p: len(p.faces))
    return out


def bumpiness(mesh: trimesh.Trimesh, iterations: int = 5) -> float:
    """Median distance [m] of the vertices from a `iterations`-step Laplacian smoothing of the mesh: a real
    YCB scan's is 0.3-1 mm, a clean recipe mesh's (flat faces) far less."""
    import trimesh.smoothing

    smooth = mesh.copy()
    trimesh.smoothing.filter_laplacian(smooth, iterations=iterations)
    return float(np.median(np.linalg.norm(np.asarray(mesh.vertices) - np.asarray(smooth.vertices), axis=1)))
