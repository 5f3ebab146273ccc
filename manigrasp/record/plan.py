"""Recording a planner's candidates: the object with every candidate as a gripper marker coloured by score.

    >>> result = planners.plan(planner, observation, hand, 100, rng)
    >>> record_plan("plan.rrd", observation, result.candidates, title=f"{result.planner} on {name}")

Entities: ``world/object`` (mesh or point cloud), ``world/table``,
``world/candidates`` (one marker per candidate: a U for the fingers, opened to
the planned width, and a stem back along the approach axis; red = lowest
score, green = highest), ``world/candidates/tcp`` (labelled "#rank score"),
``world/candidates/contacts``; on the ``rank`` timeline, ``world/selected``
steps through the candidates best first as full TCP frames; ``plan`` is the
ranking as a table. Poses are (4, 4) world matrices [m].
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import rerun as rr

from manigrasp.record import layout
from manigrasp.record.static import markdown_table, pose_transform
from manigrasp.record.streams import open_file_stream, release_streams

FINGER_LENGTH = 0.04  # [m] drawn finger and stem length
DEFAULT_HALF_WIDTH = 0.04  # [m] half-opening drawn for a candidate without a width
_LOW, _MID, _HIGH = np.array([220, 40, 40]), np.array([240, 200, 40]), np.array([40, 190, 70])


def score_colors(scores: np.ndarray) -> np.ndarray:
    """(n, 4) uint8 RGBA: red (lowest score) through yellow to green (highest); all green if equal."""
    scores = np.asarray(scores, float)
    finite = np.isfinite(scores)
    low, high = (scores[finite].min(), scores[finite].max()) if finite.any() else (0.0, 0.0)
    u = np.where(finite, (scores - low) / (high - low), 0.0) if high > low else np.ones(len(scores))
    u = u[:, None]
    rgb = np.where(u < 0.5, _LOW + (_MID - _LOW) * 2 * u, _MID + (_HIGH - _MID) * (2 * u - 1))
    return np.column_stack([rgb, np.full(len(scores), 255)]).astype(np.uint8)


def gripper_strips(pose: np.ndarray, half_width: float) -> list[np.ndarray]:
    """Two polylines of a parallel-gripper marker at TCP `pose` (4, 4): fingers + base, and the stem."""
    tcp, y, z = pose[:3, 3], pose[:3, 1], pose[:3, 2]
    tip1, tip2 = tcp - half_width * y, tcp + half_width * y
    base1, base2 = tip1 - FINGER_LENGTH * z, tip2 - FINGER_LENGTH * z
    mid = (base1 + base2) / 2
    return [np.array([tip1, base1, base2, tip2]), np.array([mid, mid - FINGER_LENGTH * z])]


def _log_object(stream: rr.RecordingStream, observation: Any) -> None:
    if getattr(observation, "mesh", None) is not None:
        mesh = observation.world_mesh()
        stream.log("world/object", rr.Mesh3D(vertex_positions=np.asarray(mesh.vertices, np.float32),
                                             triangle_indices=np.asarray(mesh.faces, np.uint32),
                                             vertex_normals=np.asarray(mesh.vertex_normals, np.float32),
                                             albedo_factor=(0.75, 0.6, 0.4, 1.0)), static=True)
    elif getattr(observation, "points", None) is not None:
        stream.log("world/object", rr.Points3D(observation.points, radii=0.001), static=True)
    center = np.asarray(observation.object_pose)[:3, 3]
    height = float(getattr(observation, "table_height", 0.0))
    stream.log("world/table", rr.Boxes3D(centers=[[center[0], center[1], height - 0.005]],
                                         half_sizes=[[0.2, 0.2, 0.005]], colors=[(140, 115, 90, 255)],
                                         fill_mode="solid"), static=True)


def _ranking(candidates: Sequence[Any], title: str) -> str:
    rows = [(f"#{i + 1}", f"score {c.score:.4g}, width {_mm(c.width)}, eps {_num(c.epsilon_l1)}, "
                          f"closure {c.force_closure}") for i, c in enumerate(candidates)]
    return markdown_table(title, rows or [("no candidates", "-")])


def _mm(width: float | None) -> str:
    return "-" if width is None else f"{1000 * width:.1f} mm"


def _num(value: float | None) -> str:
    return "-" if value is None else f"{value:.4g}"


def record_plan(path: str | Path, observation: Any, candidates: Sequence[Any], title: str = "plan",
                frame_length: float = 0.05) -> Path:
    """Write the object and `candidates` (best first, `GraspCandidate`s) to the `.rrd` file `path`."""
    path = Path(path)
    stream = open_file_stream(path, title, layout.plan_blueprint())
    try:
        stream.send_recording_name(title)
        _log_object(stream, observation)
        stream.log("plan", rr.TextDocument(_ranking(candidates, title), media_type="text/markdown"), static=True)
        if candidates:
            _log_candidates(stream, candidates, frame_length)
    finally:
        stream.flush()
        stream.disconnect()
        del stream
        release_streams()
    return path


def _log_candidates(stream: rr.RecordingStream, candidates: Sequence[Any], frame_length: float) -> None:
    colors = score_colors(np.array([c.score for c in candidates]))
    strips, strip_colors = [], []
    for c, color in zip(candidates, colors, strict=True):
        half = c.width / 2 if c.width else DEFAULT_HALF_WIDTH
        for strip in gripper_strips(np.asarray(c.pose), half):
            strips.append(strip)
            strip_colors.append(color)
    stream.log("world/candidates", rr.LineStrips3D(strips, colors=strip_colors, radii=0.0008), static=True)
    tcp = np.array([np.asarray(c.pose)[:3, 3] for c in candidates])
    labels = [f"#{i + 1} {c.score:.3g}" for i, c in enumerate(candidates)]
    stream.log("world/candidates/tcp", rr.Points3D(tcp, colors=colors, radii=0.002, labels=labels,
                                                   show_labels=False), static=True)
    contacts = [np.asarray(c.contacts).reshape(-1, 3) for c in candidates]
    if sum(len(p) for p in contacts):
        contact_colors = np.concatenate([np.repeat(col[None], len(p), 0) for col, p in zip(colors, contacts,
                                                                                           strict=True)])
        stream.log("world/candidates/contacts", rr.Points3D(np.concatenate(contacts), colors=contact_colors,
                                                            radii=0.0015), static=True)
    for rank, c in enumerate(candidates):
        stream.set_time("rank", sequence=rank + 1)
        stream.log("world/selected", pose_transform(np.asarray(c.pose)), rr.TransformAxes3D(frame_length))
        stream.log("world/selected/label", rr.TextLog(f"#{rank + 1}: score {c.score:.4g}"))
