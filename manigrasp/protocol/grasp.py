"""The grasp a protocol executes, how any planned grasp converts to it, and why one cannot be executed.

A leaf module (NumPy, `manigrasp.geometry`, the hand's description and the result records only):
the protocol's machinery (`execution`, `trial`, `base`) and the recorder import it, it imports none
of them. Poses are (4, 4) world matrices [m] (z approach, y closing).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from manigrasp.geometry import pose_from_pos_quat, quaternion_defect, rigid_defect
from manigrasp.hands.base import Hand
from manigrasp.protocol.result import GraspMetrics

PREGRASP_OFFSET = 0.10  # [m], DESIGN.md: the open hand starts 10 cm back along the approach axis


@dataclass(frozen=True, eq=False)
class Grasp:
    """The part of a planned grasp a protocol executes (a `GraspCandidate` converts to it).

    Nothing is validated here: a non-finite or non-rigid pose must reach the
    protocol, which records it as `invalid_grasp` (`check_grasp`).

    Attributes:
        pose: (4, 4) TCP pose in the world (z approach, y closing) [m], or (7,) position [m] and
            unit quaternion (w, x, y, z).
        preshape: hand synergy of the open pre-shape in [0, 1] (0 = fully open; with `joints`:
            the point of the grasp's own path the hand starts at).
        width: planned jaw opening at contact [m], or None (informational).
        contacts: (k, 3) planned contact points in the world [m].
        contact_normals: (k, 3) unit normals at `contacts`, pointing into the object.
        contact_friction: (k, 2) sliding [-] and torsional [m] friction of the hand surface at each contact, or
            None: the hand's grasping surfaces' (`manigrasp.planners.GraspCandidate.contact_friction`).
        planning_time_s: the planner's time for this grasp [s] (NaN: unknown).
        planned_metrics: the metrics of `contacts` if already computed (the harness scores a
            whole plan at once with `protocol.metrics.planned_metrics_batch`); None: computed here.
        invalid: why the grasp cannot be executed, as its planner declared ("": it may be); the
            trial is then `invalid_grasp` with this detail.
        joints: (2, n_actuators) the grasp's own hand path in actuator command units (joint angles
            [rad] of position servos, in `Hand.actuators` order): row 0 the pre-shape, row 1 the
            squeeze target; the synergy s drives ctrl = (1 - s) joints[0] + s joints[1]. None: the
            hand's own open/closed path. Dexterous hands only.
        pregrasp_offset: how far back along the approach the open hand starts [m] (the distance
            its planner checked for collisions); None: the protocol's `pregrasp_offset`.
    """

    pose: np.ndarray
    preshape: float = 0.0
    width: float | None = None
    contacts: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    contact_normals: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    contact_friction: np.ndarray | None = None
    planning_time_s: float = float("nan")
    planned_metrics: GraspMetrics | None = None
    invalid: str = ""
    joints: np.ndarray | None = None
    pregrasp_offset: float | None = None


def as_grasp(grasp: Any) -> Grasp:
    """A `Grasp` from a `Grasp`, a `manigrasp.planners.GraspCandidate` (or anything with a
    ``pose`` attribute and optionally its other fields), or a bare (4, 4) TCP pose.

    Raises TypeError or ValueError for fields that are not numbers (the protocol records that
    as `invalid_grasp`)."""
    if isinstance(grasp, Grasp):
        return grasp
    if not hasattr(grasp, "pose"):
        return Grasp(pose=np.asarray(grasp, dtype=float))
    contacts = np.asarray(getattr(grasp, "contacts", np.zeros((0, 3))), float).reshape(-1, 3)
    normals = np.asarray(getattr(grasp, "contact_normals", np.zeros((0, 3))), float).reshape(-1, 3)
    timing = getattr(grasp, "planning_time_s", float("nan"))
    joints = getattr(grasp, "joints", None)
    offset = getattr(grasp, "pregrasp_offset", None)
    friction = getattr(grasp, "contact_friction", None)
    return Grasp(pose=np.asarray(grasp.pose, dtype=float), preshape=float(getattr(grasp, "preshape", 0.0) or 0.0),
                 width=getattr(grasp, "width", None), contacts=contacts, contact_normals=normals,
                 contact_friction=None if friction is None else np.asarray(friction, float).reshape(-1, 2),
                 planning_time_s=float(timing) if timing is not None else float("nan"),
                 invalid=str(getattr(grasp, "invalid", "") or ""),
                 joints=None if joints is None else np.asarray(joints, dtype=float),
                 pregrasp_offset=None if offset is None else float(offset))


def check_grasp(grasp: Grasp, hand: Hand | None = None, ctrlrange: np.ndarray | None = None) -> str | None:
    """Why `grasp` cannot be executed, or None: declared invalid, a pose that is not a finite rigid
    transform (`manigrasp.geometry.RIGID_TOLERANCE`), a non-unit quaternion, a pre-shape outside
    [0, 1], a negative pre-grasp offset, or bad `joints` (`joints_defect`, checked against `hand` and
    the hand actuators' `ctrlrange` (n_act, 2) when given)."""
    if grasp.invalid:
        return grasp.invalid
    pose = np.asarray(grasp.pose, float)
    if pose.shape == (7,):
        if not np.all(np.isfinite(pose[:3])):
            return "grasp position is not finite"
        defect = quaternion_defect(pose[3:])
        if defect is not None:
            return f"grasp quaternion {defect}"
    elif pose.shape != (4, 4):
        return f"grasp pose must be (4, 4) or (7,) (pos, quat), got shape {pose.shape}"
    else:
        defect = rigid_defect(pose)
        if defect is not None:
            return f"grasp pose {defect}"
    if not (np.isfinite(grasp.preshape) and 0.0 <= grasp.preshape <= 1.0):
        return f"pre-shape must be in [0, 1], got {grasp.preshape}"
    offset = grasp.pregrasp_offset
    if offset is not None and not (np.isfinite(offset) and offset >= 0):
        return f"pre-grasp offset must be a finite distance >= 0 [m], got {offset}"
    if grasp.joints is not None:
        return joints_defect(grasp.joints, hand, ctrlrange)
    return None


def joints_defect(joints: Any, hand: Hand | None = None, ctrlrange: np.ndarray | None = None, *,
                  executable: bool = True) -> str | None:
    """Why `joints` is not a valid per-grasp hand path for `hand` (a sentence), or None.

    Valid: a finite (2, hand.n_actuators) array (row 0 pre-shape, row 1 squeeze target) of a
    dexterous hand, inside `ctrlrange` (n_act, 2) [lower, upper] where given (NaN rows: unlimited),
    with at least one actuator that moves between the rows. Without `hand` only the shape
    (2, n) and finiteness are checked. `executable` False: only the structure (hand kind, shape,
    finiteness), as a planner's output is checked; whether the path can be executed (rows that differ,
    inside `ctrlrange`) is then the protocol's to decide (`invalid_grasp`).
    """
    try:
        values = np.asarray(joints, dtype=float)
    except (TypeError, ValueError):
        return "joints are not numbers"
    if hand is not None and hand.kind != "dexterous":
        return f"joints are given, but hand {hand.name!r} is a {hand.kind} hand (joints are for dexterous hands)"
    n = hand.n_actuators if hand is not None else (values.shape[1] if values.ndim == 2 else -1)
    if values.ndim != 2 or values.shape != (2, n):
        want = f"(2, {n})" if hand is not None else "(2, n_actuators)"
        return f"joints must be {want} (pre-shape row, squeeze row), got shape {values.shape}"
    if not np.all(np.isfinite(values)):
        return "joints contain NaN or inf"
    if not executable:
        return None
    if not np.any(values[0] != values[1]):
        return "joints: the pre-shape and squeeze rows are equal (no actuator closes)"
    if ctrlrange is not None:
        low, high = np.asarray(ctrlrange, float).T
        outside = (values < np.where(np.isnan(low), -np.inf, low)) | (values > np.where(np.isnan(high), np.inf, high))
        if outside.any():
            row, col = (int(v[0]) for v in np.nonzero(outside))
            name = hand.actuators[col] if hand is not None else f"#{col}"
            return (f"joints: {'squeeze' if row else 'pre-shape'} command {values[row, col]:.4g} of actuator {name!r} "
                    f"is outside its ctrlrange [{low[col]:.4g}, {high[col]:.4g}]")
    return None


def grasp_tcp_pose(grasp: Grasp) -> np.ndarray:
    """(4, 4) TCP pose of a grasp that passed `check_grasp` (a (7,) pos+quat becomes a matrix)."""
    pose = np.asarray(grasp.pose, float)
    if pose.shape != (7,):
        return pose.copy()
    quat = pose[3:] / np.linalg.norm(pose[3:])
    return pose_from_pos_quat(pose[None, :3], quat[None])[0]
