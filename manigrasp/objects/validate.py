"""Validate and repair a mesh so it can be simulated, and say what was done.

Checks in order: non-finite vertices (refused), degenerate and duplicate faces
(removed), inconsistent winding (fixed), open boundaries (holes filled; if that
fails, refused unless the caller asks for the convex hull), disconnected pieces
(small debris dropped), zero volume (refused), units (refused with a --scale
suggestion). Every change is appended to `MeshReport.repairs`.
"""

from __future__ import annotations

import contextlib
import os
import sys
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np
import trimesh

from manigrasp.errors import MeshError, MeshUnitsError

MAX_EXTENT_M = 1.5
MIN_EXTENT_M = 0.005
DEBRIS_VOLUME_FRACTION = 0.01
# Open pieces (no volume yet) smaller in area than this fraction of the largest piece are debris [-].
DEBRIS_AREA_FRACTION = 0.01
# Pieces whose union is smaller than their summed volume by more than this fraction overlap [-] (manifold3d
# computes in single precision: disjoint pieces lose up to about 1e-7).
OVERLAP_TOLERANCE = 1e-4
# Mesh units other than metres, by their factor to metres (STL and OBJ carry none).
UNITS = {0.001: "millimetres", 0.01: "centimetres", 0.0254: "inches"}


@dataclass
class MeshReport:
    """What validation found and changed."""

    repairs: list[str] = field(default_factory=list)
    watertight: bool = False
    pieces: int = 1
    warnings: list[str] = field(default_factory=list)
    """What repair tools printed (MeshFix's "could not fix everything"), one line each."""


def validate_and_repair(
    mesh: trimesh.Trimesh, *, source: str = "mesh", convex_hull_fallback: bool = False, scale: float = 1.0
) -> tuple[trimesh.Trimesh, MeshReport]:
    """A repaired copy of `mesh` and the report of what was done.

    Args:
        mesh: triangle mesh in metres.
        source: name used in messages (file path or object name).
        convex_hull_fallback: if holes cannot be closed, use the convex hull
            instead of refusing (recorded as a repair).
        scale: the factor already applied to the file's vertices (the units hint is for the file).

    Raises:
        MeshError: empty, non-finite, open beyond repair, or zero volume.
        MeshUnitsError: extents outside [5 mm, 1.5 m].
    """
    report = MeshReport()
    with np.errstate(divide="ignore", invalid="ignore"):  # trimesh divides by a zero volume on flat meshes
        mesh = _clean(mesh.copy(), source, report)
        mesh = _close(mesh, source, report, convex_hull_fallback)
        mesh = _drop_debris(mesh, report)
        volume = float(mesh.volume)
    if volume <= 1e-12:
        raise MeshError(f"{source}: mesh encloses no volume (flat or degenerate)")
    check_units(mesh, source, scale)
    report.watertight = bool(mesh.is_watertight)
    return mesh, report


def check_units(mesh: trimesh.Trimesh, source: str = "mesh", scale: float = 1.0) -> None:
    """Refuse extents that say the mesh is not in metres; say the scale of each usual unit the file (before the
    `scale` already applied) fits."""
    extent = float(np.max(mesh.extents))
    if MIN_EXTENT_M <= extent <= MAX_EXTENT_M:
        return
    raw = extent / scale
    options = "; ".join(f"in {UNITS[f]}, `--scale {f:g}` ({raw * f:.3g} m)" for f in suggest_scales(raw))
    given = f" at scale {scale:g}" if scale != 1.0 else ""
    raise MeshUnitsError(
        f"{source}: largest extent is {extent:g} m{given}, outside [{MIN_EXTENT_M:g}, {MAX_EXTENT_M:g}] m; the "
        f"file is probably not in metres: " + (f"{options} (in a config: `scale:`)" if options else
                                               "scale it to metres (`--scale`, in a config `scale:`)")
    )


def suggest_scales(extent: float) -> list[float]:
    """The factors of the usual mesh units (`UNITS`: mm, cm, inch, in that order) that bring `extent` [m] within
    the extents accepted (a 30-unit part is 3 cm in mm, 30 cm in cm: the file cannot say which)."""
    return [f for f in UNITS if MIN_EXTENT_M <= extent * f <= MAX_EXTENT_M]


def _clean(mesh: trimesh.Trimesh, source: str, report: MeshReport) -> trimesh.Trimesh:
    if len(mesh.faces) == 0 or len(mesh.vertices) == 0:
        raise MeshError(f"{source}: mesh is empty")
    bad = ~np.isfinite(mesh.vertices).all(axis=1)
    if bad.any():
        raise MeshError(f"{source}: {int(bad.sum())} vertices have NaN or infinite coordinates")
    n_vertices = len(mesh.vertices)
    mesh.merge_vertices()
    if len(mesh.vertices) < n_vertices:
        report.repairs.append(f"merged {n_vertices - len(mesh.vertices)} duplicate vertices")
    keep = mesh.nondegenerate_faces()
    if not keep.all():
        report.repairs.append(f"removed {int((~keep).sum())} degenerate faces")
        mesh.update_faces(keep)
    unique = mesh.unique_faces()
    if not unique.all():
        report.repairs.append(f"removed {int((~unique).sum())} duplicate faces")
        mesh.update_faces(unique)
    mesh.remove_unreferenced_vertices()
    if len(mesh.faces) == 0:
        raise MeshError(f"{source}: no non-degenerate faces left")
    if not mesh.is_winding_consistent:
        trimesh.repair.fix_winding(mesh)
        report.repairs.append("made face winding consistent")
    return mesh


def _close(
    mesh: trimesh.Trimesh, source: str, report: MeshReport, convex_hull_fallback: bool
) -> trimesh.Trimesh:
    if not mesh.is_watertight:
        holes_before, mesh_before = _boundary_edges(mesh), mesh.copy()
        trimesh.repair.fill_holes(mesh)
        if not mesh.is_watertight:
            mesh = _meshfix_pieces(mesh, report)
        if not mesh.is_watertight:
            mesh = _fan_fill(mesh, report)
        if mesh.is_watertight:
            report.repairs.append(f"closed holes ({holes_before} open edges)" if holes_before else
                                  f"made manifold ({_nonmanifold_edges(mesh_before)} edges shared by more than two "
                                  "faces)")
            # MeshFix complains of what it could not fix even where the mesh ends closed (by MeshFix itself, another
            # piece's repair or the fan fill): say so, or a closed mesh's build line reads as a failed repair.
            report.warnings[:] = [f"{w} (the mesh ended closed)" if w.startswith("MeshFix:") else w
                                  for w in report.warnings]
        elif convex_hull_fallback:
            report.repairs.append(f"replaced by its convex hull ({holes_before} open edges could not be closed)")
            try:
                mesh = mesh.convex_hull
            except Exception as exc:  # Qhull on 3 points or a flat set: QhullError, a traceback before
                raise MeshError(f"{source}: mesh encloses no volume (flat or degenerate): its convex hull cannot be "
                                f"built ({type(exc).__name__})") from None
        else:
            raise MeshError(
                f"{source}: mesh is open ({_boundary_edges(mesh)} boundary edges) and hole filling failed; "
                "close its holes, or give its convex hull as the mesh file (`manigrasp objects build --mesh FILE "
                "--convex-hull` builds one object from its hull; a benchmark config has no such option)"
            )
    if mesh.volume < 0:
        mesh.invert()
        report.repairs.append("inverted inside-out mesh")
    trimesh.repair.fix_normals(mesh)
    return mesh


def _meshfix_pieces(mesh: trimesh.Trimesh, report: MeshReport) -> trimesh.Trimesh:
    """`_meshfix`, which keeps only the largest connected piece of what it is given: a mesh of several pieces
    (any two with areas within `DEBRIS_AREA_FRACTION` of the largest) is repaired piece by piece, its closed
    pieces kept as they are, so that a second body (a box beside an open tube, two boxes sharing an edge) is
    not silently lost. Small pieces still open after MeshFix are dropped as debris, and recorded. A mesh of one
    such piece (and debris) is given to MeshFix whole, as before."""
    pieces = mesh.split(only_watertight=False)
    areas = np.array([float(p.area) for p in pieces])
    large = areas >= DEBRIS_AREA_FRACTION * areas.max() if len(pieces) else areas.astype(bool)
    if int(large.sum()) <= 1:
        return _meshfix(mesh, report)
    kept, dropped = [], 0
    for piece, is_large in zip(pieces, large, strict=True):
        if not piece.is_watertight:
            piece = _meshfix(piece, report)
        if piece.is_watertight or is_large:  # a large piece still open leaves the mesh open: refused by the caller
            kept.append(piece)
        else:
            dropped += 1
    report.warnings[:] = list(dict.fromkeys(report.warnings))
    report.repairs.append(f"repaired {int(large.sum())} pieces one by one (MeshFix keeps one piece of a mesh)")
    if dropped:
        report.repairs.append(f"dropped {dropped} small open pieces that could not be closed")
    return trimesh.util.concatenate(kept)


def _meshfix(mesh: trimesh.Trimesh, report: MeshReport) -> trimesh.Trimesh:
    """Manifold reconstruction by MeshFix (fills holes of any shape, removes
    self-intersections); returns `mesh` unchanged if MeshFix gives nothing.
    What MeshFix prints on stderr goes to `report.warnings` (prefixed "MeshFix: ")."""
    import pymeshfix

    with _captured_stderr() as printed:
        vertices, faces = pymeshfix.clean_from_arrays(
            np.ascontiguousarray(mesh.vertices, dtype=np.float64), np.ascontiguousarray(mesh.faces, dtype=np.int32))
    lines = [line.strip() for line in printed[0].splitlines() if line.strip()]
    report.warnings.extend(f"MeshFix: {line.removeprefix('MeshFix ')}" for line in dict.fromkeys(lines))
    if len(faces) == 0:
        return mesh
    return trimesh.Trimesh(vertices, faces, process=True)


FAN_FILL_MAX_EDGES = 64
"""Longest boundary loop `_fan_fill` closes [edges]: what MeshFix leaves open is a few small loops (a hexagon of
6 edges on a Poisson-reconstructed scan, which trimesh's fill_holes, triangles and quads only, does not close)."""

FAN_FILL_MAX_AREA = 0.01
"""Largest area `_fan_fill` adds, as a fraction of the mesh's: it closes holes, it does not make up missing surface
(an open sheet stays refused)."""


def _fan_fill(mesh: trimesh.Trimesh, report: MeshReport) -> trimesh.Trimesh:
    """Close each boundary loop of at most `FAN_FILL_MAX_EDGES` edges by a fan of triangles about a new vertex at
    its centroid, wound against the loop's faces. Returns `mesh` unchanged unless that makes it watertight with
    consistent winding, adding at most `FAN_FILL_MAX_AREA` of its area (a loop that is not a simple cycle, a loop
    too long, or a vertex on two loops: unchanged)."""
    edges = np.asarray(mesh.edges)  # directed, as the faces wind them
    _, inverse, counts = np.unique(np.sort(edges, axis=1), axis=0, return_inverse=True, return_counts=True)
    boundary = edges[counts[inverse.ravel()] == 1]
    if len(boundary) == 0:
        return mesh
    following = dict(zip(boundary[:, 0].tolist(), boundary[:, 1].tolist(), strict=True))
    if len(following) != len(boundary):  # a vertex starts two boundary edges: not simple loops
        return mesh
    loops, seen = [], set()
    for start in following:
        if start in seen:
            continue
        loop, vertex = [], start
        while vertex not in seen:
            seen.add(vertex)
            loop.append(vertex)
            vertex = following.get(vertex)
            if vertex is None:
                return mesh
        if vertex != start or len(loop) > FAN_FILL_MAX_EDGES:
            return mesh
        loops.append(loop)
    vertices = [np.asarray(mesh.vertices)]
    faces = [np.asarray(mesh.faces)]
    index = len(mesh.vertices)
    for loop in loops:
        vertices.append(np.asarray(mesh.vertices)[loop].mean(axis=0, keepdims=True))
        a = np.asarray(loop)
        faces.append(np.column_stack([np.roll(a, -1), a, np.full(len(a), index)]))
        index += 1
    filled = trimesh.Trimesh(np.vstack(vertices), np.vstack(faces), process=False)
    added = filled.area_faces[len(mesh.faces):].sum()
    if not (filled.is_watertight and filled.is_winding_consistent) or added > FAN_FILL_MAX_AREA * mesh.area:
        return mesh
    report.repairs.append(f"closed {len(loops)} hole(s) MeshFix left open ({len(boundary)} edges) with fans of "
                          "triangles")
    return filled


@contextlib.contextmanager
def _captured_stderr() -> Iterator[list[str]]:
    """What C code writes to file descriptor 2 inside the block (the list's one item, set on exit)."""
    out = [""]
    sys.stderr.flush()
    saved = os.dup(2)
    with tempfile.TemporaryFile() as tmp:
        os.dup2(tmp.fileno(), 2)
        try:
            yield out
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            tmp.seek(0)
            out[0] = tmp.read().decode(errors="replace")


def _nonmanifold_edges(mesh: trimesh.Trimesh) -> int:
    _, counts = np.unique(mesh.edges_sorted, axis=0, return_counts=True)
    return int((counts > 2).sum())


def _boundary_edges(mesh: trimesh.Trimesh) -> int:
    edges = mesh.edges_sorted
    _, counts = np.unique(edges, axis=0, return_counts=True)
    return int((counts == 1).sum())


def _drop_debris(mesh: trimesh.Trimesh, report: MeshReport) -> trimesh.Trimesh:
    pieces = mesh.split(only_watertight=False)
    report.pieces = len(pieces)
    if len(pieces) <= 1:
        return mesh
    pieces = _turn_outward(pieces, report)
    volumes = np.array([abs(p.volume) for p in pieces])
    keep = volumes >= DEBRIS_VOLUME_FRACTION * volumes.max()
    dropped = int((~keep).sum())
    if dropped:
        report.repairs.append(f"dropped {dropped} small disconnected pieces (<1% of the largest volume)")
    kept = [p for p, k in zip(pieces, keep, strict=True) if k]
    if len(kept) > 1:
        kept = _merge_overlaps(kept, report)
    if len(kept) > 1:
        report.repairs.append(f"{len(kept)} disconnected pieces kept as one rigid body")
    return trimesh.util.concatenate(kept)


def _turn_outward(pieces: list[trimesh.Trimesh], report: MeshReport) -> list[trimesh.Trimesh]:
    """`pieces` with each closed inside-out piece (negative volume) that lies inside no outward piece turned
    outward: it is a body of its own whose faces point in, not a cavity (an inward shell inside another piece's
    material, kept as it is). Left so, its volume was subtracted from the object's (a 5 cm cube beside an
    inverted 4 cm one: 61 cm^3 instead of 189, the centre of mass and inertia wrong)."""
    outward = [p for p in pieces if p.is_watertight and p.volume > 0]
    turned = 0
    for piece in pieces:
        if not (piece.is_watertight and piece.volume < 0):
            continue
        inside = any(np.all(o.bounds[0] <= piece.bounds[0]) and np.all(piece.bounds[1] <= o.bounds[1])
                     and np.mean(o.contains(piece.vertices)) > 0.5 for o in outward)
        if not inside:
            piece.invert()
            turned += 1
    if turned:
        report.repairs.append(f"turned {turned} inside-out pieces outward (not inside another piece: not cavities)")
    return pieces


def _merge_overlaps(pieces: list[trimesh.Trimesh], report: MeshReport) -> list[trimesh.Trimesh]:
    """The closed outward-facing `pieces` that overlap (two shells sharing volume, a box inside a box) replaced
    by their union (manifold3d): concatenated, the shared volume counts twice in the volume, mass, centre of mass
    and inertia. A mesh with an inward-facing shell (a cavity: negative volume) is kept as it is: a solid inside
    the cavity (a rattle, a container's contents) lies within the outer shell without overlapping the material,
    and the union of the outward shells would swallow it."""
    if any(p.volume < 0 for p in pieces):
        return pieces
    solid = [p for p in pieces if p.is_watertight and p.volume > 0]
    if len(solid) < 2:
        return pieces
    union = trimesh.boolean.union(solid, engine="manifold")
    summed = float(sum(p.volume for p in solid))
    if not (union.is_watertight and union.volume < summed * (1.0 - OVERLAP_TOLERANCE)):
        return pieces
    report.repairs.append(f"overlapping pieces merged into their union (volume {union.volume:.3g} m^3, "
                          f"{summed:.3g} summed)")
    return [union] + [p for p in pieces if not any(p is q for q in solid)]
