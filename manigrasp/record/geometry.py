"""The static geometry of a compiled scene as triangle meshes, named by their MJCF names.

Every geom becomes a `GeomMesh` in its body's frame: mesh geoms keep their
vertices (collision meshes are replaced by their convex hull, which is what
MuJoCo collides with), primitives are tessellated. Entity paths follow the
scene's name prefixes: body ``hand/finger1`` is ``world/hand/finger1``, its
geom ``hand/finger1_pad`` is ``world/hand/finger1/collision/finger1_pad``;
geoms that never collide (contype = conaffinity = 0) go under ``visual``.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
import trimesh
from rerun import escape_entity_path_part

WORLD = "world"
_SPHERE_SUBDIVISIONS = 2
_CYLINDER_SECTIONS = 24
_PLANE_HALF = 1.0  # [m] half-size drawn for an infinite plane


@dataclass(frozen=True)
class GeomMesh:
    """One geom as a triangle mesh in its body's frame.

    Attributes:
        entity: rerun entity path of the geom (below its body's entity).
        body: body id.
        visual: True for a geom that never collides (drawn), False for a collision geom.
        vertices: (n, 3) float32 vertices in the geom frame [m].
        faces: (m, 3) uint32 triangle indices.
        normals: (n, 3) float32 unit vertex normals (for shading).
        pos: (3,) geom position in the body frame [m].
        quat: (4,) geom orientation in the body frame, (w, x, y, z).
        rgba: (4,) colour in [0, 1].
    """

    entity: str
    body: int
    visual: bool
    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray
    pos: np.ndarray
    quat: np.ndarray
    rgba: np.ndarray


def _name(model: mujoco.MjModel, kind: mujoco.mjtObj, index: int, fallback: str) -> str:
    return mujoco.mj_id2name(model, kind, index) or f"{fallback}_{index}"


def body_entity(model: mujoco.MjModel, body: int) -> str:
    """Entity path of `body`: ``world/<prefix>/<name>`` (``world/hand/palm``); the world body is ``world``."""
    if body == 0:
        return WORLD
    name = _name(model, mujoco.mjtObj.mjOBJ_BODY, body, "body")
    prefix, _, rest = name.partition("/")
    if not rest:
        return f"{WORLD}/{escape_entity_path_part(name)}"
    return f"{WORLD}/{escape_entity_path_part(prefix)}/{escape_entity_path_part(rest)}"


def geom_entity(model: mujoco.MjModel, geom: int) -> str:
    """Entity path of `geom`: its body's path, then ``visual`` or ``collision``, then its unprefixed name.

    A world geom (the table top ``table/top``) sits at ``world/table/top``.
    """
    name = _name(model, mujoco.mjtObj.mjOBJ_GEOM, geom, "geom")
    prefix, _, rest = name.partition("/")
    body = int(model.geom_bodyid[geom])
    if body == 0:
        parts = (prefix, rest) if rest else (name,)
        return "/".join([WORLD, *(escape_entity_path_part(p) for p in parts)])
    kind = "visual" if is_visual(model, geom) else "collision"
    return f"{body_entity(model, body)}/{kind}/{escape_entity_path_part(rest or name)}"


def is_visual(model: mujoco.MjModel, geom: int) -> bool:
    """True if `geom` never collides (contype = conaffinity = 0)."""
    return model.geom_contype[geom] == 0 and model.geom_conaffinity[geom] == 0


def _mesh_arrays(model: mujoco.MjModel, geom: int, hull: bool) -> tuple[np.ndarray, np.ndarray]:
    mesh = int(model.geom_dataid[geom])
    v0, nv = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
    f0, nf = model.mesh_faceadr[mesh], model.mesh_facenum[mesh]
    vertices, faces = model.mesh_vert[v0:v0 + nv], model.mesh_face[f0:f0 + nf]
    if hull and nv > 4:
        convex = trimesh.Trimesh(vertices, faces, process=False).convex_hull
        vertices, faces = convex.vertices, convex.faces
    return vertices, faces


def _primitive(kind: int, size: np.ndarray) -> trimesh.Trimesh | None:
    g = mujoco.mjtGeom
    if kind == g.mjGEOM_BOX:
        return trimesh.creation.box(extents=2.0 * size)
    if kind == g.mjGEOM_SPHERE:
        return trimesh.creation.icosphere(_SPHERE_SUBDIVISIONS, radius=size[0])
    if kind == g.mjGEOM_ELLIPSOID:
        sphere = trimesh.creation.icosphere(_SPHERE_SUBDIVISIONS, radius=1.0)
        return sphere.apply_scale(size)
    if kind == g.mjGEOM_CAPSULE:
        return trimesh.creation.capsule(height=2.0 * size[1], radius=size[0], count=[_CYLINDER_SECTIONS] * 2)
    if kind == g.mjGEOM_CYLINDER:
        return trimesh.creation.cylinder(radius=size[0], height=2.0 * size[1], sections=_CYLINDER_SECTIONS)
    if kind == g.mjGEOM_PLANE:
        half = np.where(size[:2] > 0, size[:2], _PLANE_HALF)
        return trimesh.creation.box(extents=[2 * half[0], 2 * half[1], 1e-4])
    return None  # heightfield, SDF: not drawn


def _rgba(model: mujoco.MjModel, geom: int) -> np.ndarray:
    mat = int(model.geom_matid[geom])
    return np.array(model.mat_rgba[mat] if mat >= 0 else model.geom_rgba[geom], dtype=float)


def geom_mesh(model: mujoco.MjModel, geom: int) -> GeomMesh | None:
    """`geom` as a `GeomMesh` (None for what is not drawn: heightfields, SDFs, and fully transparent visual geoms,
    such as a compliant pad's box, whose elements are drawn instead; collision geoms are drawn whatever their rgba)."""
    visual = is_visual(model, geom)
    if visual and _rgba(model, geom)[3] <= 0.0:
        return None
    kind = int(model.geom_type[geom])
    if kind == mujoco.mjtGeom.mjGEOM_MESH:
        vertices, faces = _mesh_arrays(model, geom, hull=not visual)
    else:
        shape = _primitive(kind, np.asarray(model.geom_size[geom], float))
        if shape is None:
            return None
        vertices, faces = shape.vertices, shape.faces
    normals = trimesh.Trimesh(vertices, faces, process=False).vertex_normals
    return GeomMesh(entity=geom_entity(model, geom), body=int(model.geom_bodyid[geom]), visual=visual,
                    vertices=np.asarray(vertices, np.float32), faces=np.asarray(faces, np.uint32),
                    normals=np.asarray(normals, np.float32),
                    pos=model.geom_pos[geom].copy(), quat=model.geom_quat[geom].copy(), rgba=_rgba(model, geom))


def scene_meshes(model: mujoco.MjModel, bodies: np.ndarray | None = None) -> list[GeomMesh]:
    """Meshes of every drawable geom of `bodies` (default: all bodies), in geom order."""
    keep = np.ones(model.ngeom, bool) if bodies is None else np.isin(model.geom_bodyid, bodies)
    meshes = (geom_mesh(model, int(g)) for g in np.flatnonzero(keep))
    return [m for m in meshes if m is not None]


def hidden_collision_entities(meshes: list[GeomMesh], model: mujoco.MjModel) -> list[str]:
    """``<body>/collision`` of every body that also has visual geoms: hidden by default in the viewer."""
    with_visual = sorted({m.body for m in meshes if m.visual and m.body != 0})
    with_collision = {m.body for m in meshes if not m.visual}
    return [f"{body_entity(model, b)}/collision" for b in with_visual if b in with_collision]
