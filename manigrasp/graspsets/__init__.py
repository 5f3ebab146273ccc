"""Grasp sets in and out: manigrasp's native format (JSON or NPZ) and ACRONYM's HDF5 layout.

    >>> from manigrasp import graspsets
    >>> grasps = graspsets.read("grasps.json")     # or .npz, .h5 (ACRONYM)
    >>> grasps.poses.shape                           # (n, 4, 4) TCP poses in the object's frame

The `file` planner (`manigrasp.planners.file`) places a set on the object's settled pose;
`manigrasp label` writes physics-labelled sets (`manigrasp.bench.label`).
"""

from __future__ import annotations

from pathlib import Path

from manigrasp.graspsets import acronym, native
from manigrasp.graspsets.model import GraspFileError, GraspSet, ObjectRef, placement_defect

SUFFIXES = native.SUFFIXES + acronym.SUFFIXES


def read(path: str | Path) -> GraspSet:
    """Read a grasp file by its suffix: .json / .npz (native) or .h5 / .hdf5 (ACRONYM)."""
    suffix = Path(path).suffix.lower()
    if suffix in acronym.SUFFIXES:
        return acronym.read(path)
    if suffix in native.SUFFIXES:
        return native.read(path)
    raise GraspFileError(f"{path}: unknown grasp file type {suffix or '(no suffix)'!r}; "
                         f"known: {', '.join(SUFFIXES)}")


def mesh_path(grasps: GraspSet) -> Path | None:
    """The object's mesh file the set names, resolved: an absolute path as is; a relative one against the grasp
    file's folder, then its parent and grandparent (ACRONYM's ``object/file`` is relative to the dataset root,
    ``meshes/...`` beside ``grasps/``). None if the set names no mesh; the first guess if none exists."""
    if grasps.object.mesh is None:
        return None
    mesh = Path(grasps.object.mesh)
    if mesh.is_absolute():
        return mesh
    folder = Path(grasps.source).resolve().parent
    guesses = [folder / mesh, folder.parent / mesh, folder.parent.parent / mesh]
    return next((g for g in guesses if g.is_file()), guesses[0])


def write(grasps: GraspSet, path: str | Path) -> Path:
    """Write `grasps` by `path`'s suffix (native .json / .npz, or ACRONYM .h5)."""
    suffix = Path(path).suffix.lower()
    if suffix in acronym.SUFFIXES:
        return acronym.write(grasps, path)
    return native.write(grasps, path)


__all__ = ["SUFFIXES", "GraspFileError", "GraspSet", "ObjectRef", "acronym", "mesh_path", "native", "placement_defect",
           "read", "write"]
