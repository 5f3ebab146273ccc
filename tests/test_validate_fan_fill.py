"""Holes MeshFix leaves open are closed by fans of triangles (`validate._fan_fill`): a Poisson-reconstructed scan
(the banana's and scissors' pseudo-scans of benchmarks/bench_pseudo_scans.py) came out of MeshFix with one
hexagonal hole, which trimesh's fill_holes (triangles and quads only) does not close, and was refused."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from manigrasp.errors import MeshError
from manigrasp.objects import validate
from manigrasp.objects.validate import validate_and_repair


def _sphere_with_hexagonal_hole() -> trimesh.Trimesh:
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=0.03)
    counts = np.bincount(sphere.faces.ravel())
    vertex = int(np.flatnonzero(counts == 6)[0])  # a vertex of valence 6: removing its faces opens a hexagon
    keep = ~np.any(sphere.faces == vertex, axis=1)
    mesh = trimesh.Trimesh(sphere.vertices, sphere.faces[keep])
    mesh.remove_unreferenced_vertices()
    return mesh


def test_a_hole_meshfix_leaves_is_closed(monkeypatch):
    mesh = _sphere_with_hexagonal_hole()
    trimesh.repair.fill_holes(mesh)
    assert not mesh.is_watertight  # trimesh cannot close a hexagon

    def meshfix(m, report):  # MeshFix "could not fix everything", and says so
        report.warnings.append("MeshFix: could not fix everything")
        return m

    monkeypatch.setattr(validate, "_meshfix", meshfix)
    out, report = validate_and_repair(_sphere_with_hexagonal_hole(), source="hex")
    assert out.is_watertight and out.is_winding_consistent and out.volume > 0
    assert any("fans of triangles" in r for r in report.repairs)
    # The build line read as a failed repair on a mesh that ended closed.
    assert report.warnings == ["MeshFix: could not fix everything (the mesh ended closed)"]
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=0.03)
    assert out.volume == pytest.approx(sphere.volume, rel=0.01)


def test_a_long_open_boundary_is_still_refused(monkeypatch):
    """A cut longer than FAN_FILL_MAX_EDGES is not fanned: still refused (or replaced by its hull on request)."""
    sphere = trimesh.creation.icosphere(subdivisions=4, radius=0.03)
    cap = trimesh.Trimesh(sphere.vertices, sphere.faces[sphere.triangles_center[:, 2] < 0.02])
    monkeypatch.setattr(validate, "_meshfix", lambda m, report: m)
    with pytest.raises(MeshError, match="hole filling failed"):
        validate_and_repair(cap, source="cap")
