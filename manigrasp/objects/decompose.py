"""Convex decomposition with CoACD, and a check that the hulls cover the mesh.

Defaults are chosen so that the features that matter for grasping survive:
the mug's handle hole, the bowl's cavity and the scissors' finger holes each
come out as separate hulls around an empty space (checked by the tests), at a
cost of a few seconds per object. See `DecompositionParams` for each knob.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from importlib.metadata import version

import numpy as np
import trimesh

from manigrasp.errors import DecompositionError

MIN_HULL_VOLUME_M3 = 1e-10  # hulls below this (0.1 mm^3) are numerical slivers
CONVEX_TOLERANCE = 1e-3  # a mesh within 0.1% of its hull's volume is convex: its hull is its only part


@dataclass(frozen=True)
class DecompositionParams:
    """CoACD settings (passed on as keyword arguments of `coacd.run_coacd`)."""

    threshold: float = 0.04
    """Concavity threshold (0.01 - 1): lower keeps finer concave features, costs more hulls/time."""
    max_convex_hull: int = 32
    """Upper bound on the number of hulls (-1: no bound); hulls are merged down to it."""
    preprocess_mode: str = "auto"
    """Manifold pre-processing: "auto" (only if the mesh is not manifold), "on" or "off"."""
    preprocess_resolution: int = 50
    """Voxel resolution of the pre-processing step."""
    resolution: int = 2000
    """Surface sampling resolution of the Hausdorff concavity estimate."""
    mcts_nodes: int = 20
    """Children per node of the Monte-Carlo tree search for cutting planes."""
    mcts_iterations: int = 150
    """Iterations of the tree search."""
    mcts_max_depth: int = 3
    """Depth of the tree search."""
    merge: bool = True
    """Merge hulls after decomposition where that does not raise concavity."""
    max_ch_vertex: int = 128
    """Maximum vertices per hull (MuJoCo collides faster with small hulls)."""
    seed: int = 0
    """CoACD's random seed: a fixed seed makes the decomposition reproducible."""

    def as_dict(self) -> dict:
        """The parameters as a plain dict (for cache keys and run metadata)."""
        return dataclasses.asdict(self)


def coacd_version() -> str:
    """The installed CoACD version (part of every cache key)."""
    return version("coacd")


def is_convex(mesh: trimesh.Trimesh) -> bool:
    """Whether `mesh` fills its convex hull (to `CONVEX_TOLERANCE` of the volume)."""
    return bool(mesh.volume >= (1.0 - CONVEX_TOLERANCE) * mesh.convex_hull.volume)


def decompose(mesh: trimesh.Trimesh, params: DecompositionParams) -> list[trimesh.Trimesh]:
    """Convex parts of `mesh`; each part is a closed convex hull.

    A mesh that is already convex is its own single part (its exact hull: no
    vertices dropped, so a ball keeps the flat facet it rests on); anything
    else goes through CoACD.

    Raises:
        DecompositionError: CoACD failed or returned no usable hull.
    """
    if is_convex(mesh):
        return [mesh.convex_hull]
    import coacd

    coacd.set_log_level("error")
    try:
        raw = coacd.run_coacd(coacd.Mesh(np.asarray(mesh.vertices), np.asarray(mesh.faces)), **params.as_dict())
    except Exception as exc:  # CoACD raises RuntimeError or generic exceptions from C++
        raise DecompositionError(f"CoACD failed: {exc}") from exc
    hulls = [trimesh.Trimesh(v, f).convex_hull for v, f in raw if len(f) >= 4]
    hulls = [h for h in hulls if h.volume > MIN_HULL_VOLUME_M3]
    if not hulls:
        raise DecompositionError("CoACD returned no hull with positive volume")
    return hulls


def coverage(mesh: trimesh.Trimesh, hulls: list[trimesh.Trimesh]) -> float:
    """Volume of the union of `hulls` divided by the volume of `mesh`.

    1.0 is a perfect cover; above 1 the hulls bulge out (filling concavities),
    below 1 they miss parts of the object.
    """
    union = trimesh.boolean.union(hulls, engine="manifold") if len(hulls) > 1 else hulls[0]
    return float(union.volume / mesh.volume)
