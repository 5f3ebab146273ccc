"""What a trial recording logs once: the scene's geometry, the planned grasp, the final status as text.

Poses are (4, 4) world matrices [m]; rerun quaternions are (x, y, z, w),
MuJoCo's (w, x, y, z), converted here.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from typing import Any

import mujoco
import numpy as np
import rerun as rr

from manigrasp.record import layout
from manigrasp.record.geometry import GeomMesh, hidden_collision_entities, scene_meshes

_CACHE_SIZE = 8
_MESHES: OrderedDict[int, tuple[mujoco.MjModel, list[GeomMesh], list[str]]] = OrderedDict()
IN_CONE, OUT_OF_CONE = (60, 200, 80, 255), (230, 50, 40, 255)
PLAN_COLOR = (255, 200, 0, 255)


def xyzw(wxyz: np.ndarray) -> np.ndarray:
    """(..., 4) MuJoCo (w, x, y, z) quaternions as rerun's (x, y, z, w)."""
    q = np.asarray(wxyz, float)
    return np.concatenate([q[..., 1:], q[..., :1]], axis=-1)


def pose_transform(pose: np.ndarray) -> rr.Transform3D:
    """A rerun transform of a (4, 4) pose."""
    return rr.Transform3D(translation=pose[:3, 3], mat3x3=pose[:3, :3])


def scene_geometry(model: mujoco.MjModel) -> tuple[list[GeomMesh], list[str]]:
    """(meshes of every geom, collision entities to hide) of `model`, cached per model object.

    A worker reuses one compiled scene for many trials; tessellating and taking
    convex hulls again for each recording would cost more than logging them.
    """
    key = id(model)
    hit = _MESHES.get(key)
    if hit is not None and hit[0] is model:
        _MESHES.move_to_end(key)
        return hit[1], hit[2]
    meshes = scene_meshes(model)
    hidden = hidden_collision_entities(meshes, model)
    _MESHES[key] = (model, meshes, hidden)
    while len(_MESHES) > _CACHE_SIZE:
        _MESHES.popitem(last=False)
    return meshes, hidden


def log_geometry(stream: rr.RecordingStream, meshes: list[GeomMesh], collision: bool) -> None:
    """Log every geom as a static mesh under its body (collision geoms only if `collision`
    or if their body has nothing else to draw)."""
    drawn = {m.body for m in meshes if m.visual}
    for mesh in meshes:
        if not mesh.visual and not collision and mesh.body in drawn:
            continue
        stream.log(mesh.entity,
                   rr.Transform3D(translation=mesh.pos, quaternion=rr.Quaternion(xyzw=xyzw(mesh.quat))),
                   rr.Mesh3D(vertex_positions=mesh.vertices, triangle_indices=mesh.faces,
                             vertex_normals=mesh.normals, albedo_factor=mesh.rgba),
                   static=True)


def log_planned_grasp(stream: rr.RecordingStream, pose: np.ndarray | None, pregrasp: np.ndarray | None,
                      contacts: np.ndarray, normals: np.ndarray, frame_length: float) -> None:
    """Static frames of the planned TCP and pre-grasp pose, the planned contacts and their normals (into the object)."""
    for entity, frame in ((layout.PLAN_GRASP, pose), (layout.PLAN_PREGRASP, pregrasp)):
        if frame is not None:
            stream.log(entity, pose_transform(frame), rr.TransformAxes3D(frame_length), static=True)
    if len(contacts):
        stream.log(layout.PLAN_CONTACTS, rr.Points3D(contacts, radii=0.004, colors=PLAN_COLOR), static=True)
    if len(normals) == len(contacts) and len(contacts):
        stream.log(layout.PLAN_NORMALS, rr.Arrows3D(origins=contacts, vectors=0.4 * frame_length * normals,
                                                    colors=PLAN_COLOR), static=True)


def _fmt(value: Any) -> str:
    if isinstance(value, float):
        return "-" if math.isnan(value) else f"{value:.4g}"
    if isinstance(value, tuple):
        return ", ".join(map(str, value)) or "-"
    return str(value) if value not in (None, "") else "-"


def markdown_table(title: str, rows: list[tuple[str, Any]]) -> str:
    """A two-column markdown table under a heading."""
    body = "\n".join(f"| {name} | {_fmt(value)} |" for name, value in rows)
    return f"# {title}\n\n| | |\n|---|---|\n{body}\n"


def status_rows(result: Any) -> list[tuple[str, Any]]:
    """The fields of a `TrialResult` worth reading first."""
    return [("status", result.status.value), ("detail", result.detail), ("last phase", result.last_phase),
            ("fingers in contact", tuple(result.fingers_in_contact)), ("grip force [N]", result.grip_force_n),
            ("max translation in hand [mm]", 1000.0 * result.max_translation_m),
            ("max rotation in hand [deg]", result.max_rotation_deg),
            ("simulated force closure", result.simulated.force_closure),
            ("simulated epsilon L1", result.simulated.epsilon_l1), ("sim steps", result.sim_steps),
            ("sim time [s]", result.sim_time_s), ("wall time [s]", result.wall_time_s), ("seed", result.seed)]


def plan_rows(result: Any, candidate: Any) -> list[tuple[str, Any]]:
    """The planned grasp's analytic metrics (from the result, and the candidate's own when given)."""
    rows: list[tuple[str, Any]] = [
        ("planned contacts", result.planned.n_contacts), ("force closure", result.planned.force_closure),
        ("epsilon L1", result.planned.epsilon_l1), ("min friction for closure", result.planned.min_friction),
        ("score", result.score), ("planning time [s]", result.planning_time_s)]
    if candidate is not None:
        for name in ("score", "width", "epsilon_l1", "force_closure", "min_friction"):
            if hasattr(candidate, name):
                rows.append((f"candidate {name}", getattr(candidate, name)))
    return rows
