"""From a mesh (file, recipe or array) to an `ObjectAsset` ready to simulate.

Steps: read -> bound the face count (`MAX_FACES`) -> scale -> validate and repair -> centre of mass at the origin ->
mass and inertia -> convex decomposition (cached) -> files and MJCF in the
cache folder. Every repair is recorded in the asset's metadata.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import shutil
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh

from manigrasp.contact.defaults import STANDARD_MU, STANDARD_ROLLING_M, STANDARD_TORSION_M
from manigrasp.errors import MeshError
from manigrasp.objects.asset import ObjectAsset
from manigrasp.objects.cache import HullCache, cache_key, check_name, inside, name_from_path
from manigrasp.objects.decompose import DecompositionParams, coacd_version, coverage, decompose
from manigrasp.objects.meshio import load_mesh
from manigrasp.objects.mjcf import object_mjcf
from manigrasp.objects.validate import validate_and_repair
from manigrasp.paths import cache_dir

DEFAULT_DENSITY = 500.0  # [kg/m^3], YCB-like solids without a known mass
DEFAULT_FRICTION = (STANDARD_MU, STANDARD_TORSION_M, STANDARD_ROLLING_M)  # sliding, torsional [m], rolling [m]
REFINE_ABOVE = 1.2
"""Coverage (hull union / mesh volume) above which a mesh decomposed with the default settings is decomposed again,
finer (`REFINED`), and the closer cover kept. CoACD's defaults (concavity threshold 0.04, at most 32 hulls) fill a
thin shell's cavity: a scanned bowl (`manigrasp.objects.pseudoscan`) came out 1.72, its jaw-width rim a solid wall
thicker than the real one; every shipped object decomposed with the defaults stays below 1.16 (the scissors)."""
REFINED = {"threshold": 0.03, "max_convex_hull": -1}
"""The finer settings, the bowl recipe's threshold and hull cap (`assets/objects/ycb_like.yaml`; it also turns
CoACD's pre-processing off, which a scan that is not manifold needs): the scanned bowl 1.72 -> 1.39 (32 -> 81
hulls; 58 and 95 s of CoACD on one core, once: cached)."""
MAX_FACES = 250_000
"""Largest mesh built (faces): CoACD's time and memory grow with the face count (a 2-million-face
mesh ran 5 min to 11.5 GB and aborted); a YCB google_16k mesh has ~32k faces."""


@dataclass(frozen=True)
class MassProperties:
    """Mass [kg], centre of mass (3,) [m] and inertia about it (3, 3) [kg m^2]."""

    mass: float
    com: np.ndarray
    inertia: np.ndarray


def mass_properties(mesh: trimesh.Trimesh, mass: float | None, density: float) -> MassProperties:
    """Mass properties of a closed mesh from a given mass, else from `density` [kg/m^3]."""
    volume = float(mesh.volume)
    rho = mass / volume if mass is not None else density
    if not np.isfinite(rho) or rho <= 0:
        raise ValueError(f"mass {mass} / density {density} give no positive density")
    props = mesh.mass_properties  # unit density
    return MassProperties(
        mass=rho * volume,
        com=np.asarray(props["center_mass"], float),
        inertia=rho * np.asarray(props["inertia"], float),
    )


@dataclass(frozen=True)
class BuildResult:
    """One object's build: the asset, whether CoACD ran, and the wall time [s]."""

    asset: ObjectAsset
    cached: bool
    seconds: float


def build_object(
    source: str | Path | trimesh.Trimesh,
    *,
    name: str | None = None,
    scale: float = 1.0,
    mass: float | None = None,
    density: float = DEFAULT_DENSITY,
    friction: Sequence[float] = DEFAULT_FRICTION,
    params: DecompositionParams | None = None,
    convex_hull_fallback: bool = False,
    metadata: dict | None = None,
    cache_root: Path | None = None,
) -> BuildResult:
    """Build an object from a mesh file or a `trimesh.Trimesh`.

    Args:
        source: mesh file (OBJ, STL, PLY, OFF, GLB/GLTF) or mesh, in metres after `scale`.
        name: object name (default: the file's stem).
        scale: factor applied to the vertices first (0.001 for a mesh in mm).
        mass: object mass [kg]; if None, from `density` [kg/m^3] and the volume.
        friction: (sliding, torsional, rolling) of the collision parts.
        params: CoACD parameters; None (the default): `DecompositionParams()`, and a mesh they cover by more than
            `REFINE_ABOVE` of its volume is decomposed again with `REFINED`, keeping the closer cover (the
            metadata's ``decomposition`` holds the settings kept; ``refined_from``, when the finer one is kept,
            the first cover's coverage, hull count and settings).
        convex_hull_fallback: use the convex hull of a mesh whose holes cannot be closed.
        metadata: extra facts stored in the asset's metadata (source, ycb_id...).
        cache_root: cache folder (default `manigrasp.paths.cache_dir()`).
    """
    start = time.perf_counter()
    refine = params is None
    params = params or DecompositionParams()
    label = str(source) if not isinstance(source, trimesh.Trimesh) else (name or "mesh")
    mesh = load_mesh(source) if not isinstance(source, trimesh.Trimesh) else source.copy()
    name = check_name(name) if name is not None else name_from_path(str(source))
    if len(mesh.faces) > MAX_FACES:
        raise MeshError(f"{label}: {len(mesh.faces)} faces, more than the {MAX_FACES} manigrasp builds (CoACD's "
                        "time and memory grow with them); simplify it first, e.g. open3d's "
                        "simplify_quadric_decimation or Blender's Decimate, to ~50000 faces")
    if scale != 1.0:
        mesh.apply_scale(scale)
    mesh, report = validate_and_repair(mesh, source=label, convex_hull_fallback=convex_hull_fallback, scale=scale)
    props = mass_properties(mesh, mass, density)
    mesh.apply_translation(-props.com)
    root = Path(cache_root) if cache_root is not None else cache_dir()
    cache = HullCache(root / "coacd")
    hulls, hull_meta, cached = _hulls(mesh, params, cache)
    refined_from = None
    if refine and hull_meta["coverage"] > REFINE_ABOVE:
        finer = dataclasses.replace(params, **REFINED)
        finer_hulls, finer_meta, finer_cached = _hulls(mesh, finer, cache)
        if abs(finer_meta["coverage"] - 1.0) < abs(hull_meta["coverage"] - 1.0):  # the closer cover
            refined_from = {"coverage": hull_meta["coverage"], "n_hulls": len(hulls), "decomposition": params.as_dict()}
            hulls, hull_meta, params = finer_hulls, finer_meta, finer
        cached = cached and finer_cached
    meta = {
        **(metadata or {}),
        "name": name,
        "source": (metadata or {}).get("source", label),
        "scale": scale,
        "repairs": report.repairs,
        "warnings": report.warnings,
        "pieces": report.pieces,
        "n_hulls": len(hulls),
        "coverage": hull_meta["coverage"],
        "decomposition": params.as_dict(),
        **({"refined_from": refined_from} if refined_from is not None else {}),
        "coacd_version": coacd_version(),
        "hull_key": hull_meta["key"],
        "com_offset_m": props.com.tolist(),
    }
    asset = _export(name, mesh, hulls, props, tuple(friction), meta, root / "objects")
    return BuildResult(asset=asset, cached=cached, seconds=time.perf_counter() - start)


def build_object_from_mesh(
    mesh: trimesh.Trimesh, name: str, mass: float | None = None, density: float = DEFAULT_DENSITY
) -> ObjectAsset:
    """Shorthand for `build_object(mesh, name=..., mass=..., density=...).asset`."""
    return build_object(mesh, name=name, mass=mass, density=density).asset


def _hulls(
    mesh: trimesh.Trimesh, params: DecompositionParams, cache: HullCache
) -> tuple[list[trimesh.Trimesh], dict, bool]:
    key = cache_key(mesh, params.as_dict(), coacd_version())
    hit = cache.get(key)
    if hit is not None:
        return hit[0], hit[1], True
    hulls = decompose(mesh, params)
    meta = {"key": key, "coverage": coverage(mesh, hulls)}
    cache.put(key, hulls, meta)
    return hulls, meta, False


OBJECT_FORMAT = 2
"""Format of an object folder: 2, mesh files relative to object.xml and every file checksummed
(`checksums.json`). Part of the folder's name, so folders of older formats are never read."""
_CHECKSUMS = "checksums.json"


def _export(
    name: str,
    mesh: trimesh.Trimesh,
    hulls: list[trimesh.Trimesh],
    props: MassProperties,
    friction: tuple[float, ...],
    meta: dict,
    root: Path,
) -> ObjectAsset:
    """Write visual mesh, parts, MJCF and meta.json into a folder of their own.

    An existing folder is used only if every file matches its checksum; else it is rebuilt.
    """
    fingerprint = json.dumps({"hulls": meta["hull_key"], "mass": props.mass, "friction": friction,
                              "name": name, "meta": meta, "format": OBJECT_FORMAT}, sort_keys=True, default=str)
    folder = inside(root, f"{name}-{hashlib.sha256(fingerprint.encode()).hexdigest()[:16]}")
    if not entry_is_intact(folder):
        _write_folder(folder, name, mesh, hulls, props, friction, meta)
    return ObjectAsset(
        name=name,
        visual_path=folder / "visual.obj",
        part_paths=tuple(folder / f"part_{i:03d}.obj" for i in range(len(hulls))),
        mass=props.mass,
        inertia=props.inertia,
        extents=np.asarray(mesh.extents, float),
        volume=float(mesh.volume),
        mjcf_path=folder / "object.xml",
        metadata=meta,
    )


def _file_digest(path: Path) -> str:
    with open(path, "rb") as f:
        return hashlib.file_digest(f, "sha256").hexdigest()


def entry_is_intact(folder: Path) -> bool:
    """Whether the object folder exists with every file it lists in `checksums.json`, unchanged."""
    try:
        listed = json.loads((folder / _CHECKSUMS).read_text())
        if not isinstance(listed, dict) or not {"object.xml", "meta.json", "visual.obj"} <= set(listed):
            return False
        return all(_file_digest(inside(folder, file)) == digest for file, digest in listed.items())
    except (OSError, ValueError, TypeError):
        return False


def _write_folder(folder: Path, name: str, mesh: trimesh.Trimesh, hulls: list[trimesh.Trimesh],
                  props: MassProperties, friction: tuple[float, ...], meta: dict) -> None:
    """Write the folder in a temporary folder and move it into place; a damaged folder in the
    way is moved aside first (another process may have put a good one there meanwhile)."""
    folder.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(dir=folder.parent, prefix=f".{folder.name}."))
    try:
        mesh.export(tmp / "visual.obj")
        for i, hull in enumerate(hulls):
            hull.export(tmp / f"part_{i:03d}.obj")
        parts = [Path(f"part_{i:03d}.obj") for i in range(len(hulls))]
        xml = object_mjcf(name, Path("visual.obj"), parts, props.mass, props.inertia, friction)
        (tmp / "object.xml").write_text(xml)
        (tmp / "meta.json").write_text(json.dumps(meta, indent=2, default=str))
        digests = {p.name: _file_digest(p) for p in sorted(tmp.iterdir())}
        (tmp / _CHECKSUMS).write_text(json.dumps(digests, indent=1))
        for _ in range(3):
            try:
                os.rename(tmp, folder)
                return
            except OSError:  # a folder is in the way: someone else's good one, or a damaged one
                if entry_is_intact(folder):
                    return
                _discard(folder)
        raise OSError(f"cannot replace the damaged cache entry {folder}")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def _discard(folder: Path) -> None:
    """Move a damaged folder aside (one atomic rename), then delete it."""
    trash = folder.parent / f".{folder.name}.{os.getpid()}.damaged"
    try:
        os.rename(folder, trash)
    except FileNotFoundError:
        return
    shutil.rmtree(trash, ignore_errors=True)
