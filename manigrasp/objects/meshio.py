"""Reading meshes from files and from a real YCB dataset folder.

Supported: OBJ, STL, PLY, OFF, GLB/GLTF (a scene is flattened into one mesh).
Every failure to read becomes a `MeshError` with a one-line message.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from manigrasp.errors import MeshError

MESH_SUFFIXES = (".obj", ".stl", ".ply", ".off", ".glb", ".gltf")


def names_a_path(text: str) -> bool:
    """Whether `text`, given where an object's name goes, names a file instead: a mesh file's suffix, or a
    folder separator (an object name is an identifier, `catalog.check_name`)."""
    return Path(text).suffix.lower() in MESH_SUFFIXES or "/" in text


# Sub-folders of a YCB object folder, best first (published YCB layout).
YCB_MESH_FILES = (
    "google_16k/textured.obj",
    "google_16k/nontextured.ply",
    "google_16k/nontextured.stl",
    "poisson/textured.obj",
    "poisson/nontextured.ply",
    "tsdf/textured.obj",
    "tsdf/nontextured.ply",
)


def load_mesh(path: str | Path) -> trimesh.Trimesh:
    """Read the mesh in `path` as one triangle mesh (no repair, no scaling).

    Raises:
        MeshError: the file is missing, empty, of an unknown type, not a mesh,
            or holds no triangles.
    """
    path = Path(path)
    if path.is_dir():
        raise MeshError(f"{path}: a folder, not a mesh file")
    if not path.is_file():
        raise MeshError(f"{path}: no such mesh file")
    if path.suffix.lower() not in MESH_SUFFIXES:
        raise MeshError(f"{path}: unsupported mesh type {path.suffix!r}; use one of {', '.join(MESH_SUFFIXES)}")
    if path.stat().st_size == 0:
        raise MeshError(f"{path}: file is empty")
    try:
        loaded = trimesh.load(path, force="mesh", process=False, skip_materials=True)
    except Exception as exc:  # trimesh raises many types on garbage input
        raise MeshError(f"{path}: cannot read mesh ({type(exc).__name__}: {exc})") from exc
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise MeshError(f"{path}: cannot read mesh: the file holds no triangles")
    return trimesh.Trimesh(np.asarray(loaded.vertices, float), np.asarray(loaded.faces), process=False)


def ycb_mesh_file(folder: str | Path) -> Path:
    """The best mesh file of one YCB object folder (google_16k, then poisson, then tsdf)."""
    folder = Path(folder)
    for relative in YCB_MESH_FILES:
        candidate = folder / relative
        if candidate.is_file():
            return candidate
    raise MeshError(f"{folder}: no YCB mesh found (looked for {', '.join(YCB_MESH_FILES)})")


def ycb_dataset(root: str | Path) -> dict[str, Path]:
    """Map object name ("025_mug") -> mesh file for a YCB dataset folder.

    `root` is the folder that holds one sub-folder per object, as published
    (``025_mug/google_16k/textured.obj`` ...). Folders without a mesh are skipped.
    """
    root = Path(root)
    if not root.is_dir():
        raise MeshError(f"{root}: not a folder")
    found = {}
    for folder in sorted(p for p in root.iterdir() if p.is_dir()):
        try:
            found[folder.name] = ycb_mesh_file(folder)
        except MeshError:
            continue
    if not found:
        raise MeshError(f"{root}: no YCB object folders with a mesh (expected e.g. 025_mug/google_16k/textured.obj)")
    return found
