"""The planner interface: `Observation` in, ranked `GraspCandidate`s out.

A planner is any object with a ``name``, the kind of observation it ``needs``
("mesh" or "points", or a tuple of both in order of preference: the
antipodal planner's ("mesh", "points") plans on the mesh when there is one)
and a method

    plan(observation, hand, n, rng) -> Sequence[GraspCandidate]

that returns at most `n` candidates, best first; it may also take a
``context`` keyword (`manigrasp.planners.context.PlanContext`: the executing
protocol's pre-grasp offset, grip force and loads, which the harness passes
to every planner that accepts it). It takes every random draw
from `rng` (a `numpy.random.Generator`) and reads no clock: `manigrasp.planners.run.plan`
times the call, validates what comes back and reports a failure as a `PlannerError`.

Poses are (4, 4) homogeneous matrices in the world frame [m]. A grasp pose is
the hand's TCP frame (DESIGN.md): z = approach (hand toward object),
y = closing (finger 1 toward finger 2), x = y cross z.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Literal, Protocol, runtime_checkable

import numpy as np
import trimesh

from manigrasp.errors import PlannerError
from manigrasp.geometry import pose_from_pos_quat, pregrasp_pose, quaternion_defect
from manigrasp.hands.base import Hand
from manigrasp.objects.asset import ObjectAsset
from manigrasp.protocol.grasp import PREGRASP_OFFSET

ObservationKind = Literal["mesh", "points"]


def _readonly(array: object) -> np.ndarray:
    """A read-only float copy of `array`."""
    out = np.array(array, dtype=float)
    out.setflags(write=False)
    return out


@dataclass(frozen=True, eq=False)
class Observation:
    """What a planner sees of the object.

    Ground truth ("mesh"): the object's mesh in its own frame and its resting
    pose. Perception ("points"): a point cloud with normals in the world
    frame (one view: noisy, partial, table removed). Either may be given;
    `kinds` says which a planner can rely on. The antipodal planner's cloud
    path reads only the points, normals and table height (it estimates the
    centre of mass itself; an identity or estimated `object_pose` is ignored).

    Attributes:
        object_pose: (4, 4) pose of the object frame (origin = centre of mass) in the world.
        mesh: closed surface mesh in the object frame [m], or None.
        points: (n, 3) surface points in the world [m], or None.
        normals: (n, 3) outward unit normals at `points`, or None.
        asset: the built object (its convex parts give the exact collision
            geometry for collision checks), or None: then checks use the
            convex hull of `mesh` (conservative).
        table_height: z of the table top in the world [m]; nothing may
            approach from below it.
    """

    object_pose: np.ndarray
    mesh: trimesh.Trimesh | None = None
    points: np.ndarray | None = None
    normals: np.ndarray | None = None
    asset: ObjectAsset | None = None
    table_height: float = 0.0

    def __post_init__(self) -> None:
        pose = _readonly(self.object_pose)
        if pose.shape != (4, 4) or not np.all(np.isfinite(pose)):
            raise PlannerError(f"object_pose must be a finite (4, 4) matrix, got shape {pose.shape}")
        object.__setattr__(self, "object_pose", pose)
        if self.mesh is None and self.points is None:
            raise PlannerError("an Observation needs a mesh or a point cloud")
        if (self.points is None) != (self.normals is None):
            raise PlannerError("points and normals come together")
        if self.points is not None:
            points, normals = np.asarray(self.points, float), np.asarray(self.normals, float)
            if points.ndim != 2 or points.shape[1] != 3 or normals.shape != points.shape:
                raise PlannerError(f"points and normals must both be (n, 3), got {points.shape}, {normals.shape}")
            object.__setattr__(self, "points", _readonly(points))
            object.__setattr__(self, "normals", _readonly(normals))

    @property
    def kinds(self) -> tuple[ObservationKind, ...]:
        """The kinds of observation this holds ("mesh", "points" or both)."""
        out: list[ObservationKind] = []
        if self.mesh is not None:
            out.append("mesh")
        if self.points is not None:
            out.append("points")
        return tuple(out)

    @property
    def center_of_mass(self) -> np.ndarray:
        """(3,) the object frame's origin in the world [m] (the centre of mass of a built object)."""
        return self.object_pose[:3, 3].copy()

    def world_mesh(self) -> trimesh.Trimesh:
        """A copy of `mesh` moved to the object's pose in the world."""
        if self.mesh is None:
            raise PlannerError("this observation has no mesh")
        return self.mesh.copy().apply_transform(self.object_pose)

    def object_mass(self, density: float) -> float:
        """The object's mass [kg]: the built asset's, else `density` [kg/m^3] x the world mesh's volume (its
        convex hull's where the mesh is not watertight)."""
        if self.asset is not None:
            return float(self.asset.mass)
        mesh = self.world_mesh()
        return density * float(mesh.volume if mesh.is_watertight else mesh.convex_hull.volume)

    @classmethod
    def from_asset(cls, asset: ObjectAsset, object_pose: np.ndarray | None = None,
                   table_height: float = 0.0) -> Observation:
        """Ground truth of a built object: its visual mesh and pose (default: resting upright on the table)."""
        mesh = trimesh.load(str(asset.visual_path), force="mesh", process=False)
        pose = resting_pose(asset, table_height) if object_pose is None else object_pose
        return cls(object_pose=pose, mesh=mesh, asset=asset, table_height=table_height)


def resting_pose(asset: ObjectAsset, table_height: float = 0.0) -> np.ndarray:
    """(4, 4) pose of `asset` upright (object frame axes = world axes) on the table at x = y = 0.

    The height puts the lowest point of its collision parts on the table, as
    `manigrasp.sim.Scene.object_rest_pose` does.
    """
    paths = asset.part_paths or (asset.visual_path,)
    lowest = min(float(trimesh.load(str(p), force="mesh", process=False).vertices[:, 2].min()) for p in paths)
    pose = np.eye(4)
    pose[2, 3] = table_height - lowest
    return pose


@dataclass(frozen=True, eq=False)
class GraspCandidate:
    """One planned grasp.

    Attributes:
        pose: (4, 4) TCP pose in the world (z approach, y closing) [m].
        score: the planner's ranking score (higher is better; each planner documents its own).
        width: planned jaw opening at contact [m] (distance between the two
            planned contacts of a parallel grasp), or None.
        preshape: hand synergy of the pre-shape in [0, 1] (0 = fully open).
        contacts: (k, 3) planned contact points in the world [m] (k may be 0).
        contact_normals: (k, 3) unit contact normals pointing INTO the object.
        contact_friction: (k, 2) the sliding [-] and torsional [m] friction of the hand surface each
            planned contact lies on, where the planner knows it (the power planner: the touching geom's, as
            its probe compiled it); None: the hand's grasping surfaces' (`protocol.metrics.grasping_contact`).
            The stored planned metrics use it.
        epsilon_l1: Ferrari-Canny epsilon (L1) of the planned contacts, or None if not computed.
        force_closure: whether the planned contacts are in force closure, or None.
        min_friction: smallest friction coefficient for force closure of the planned contacts, or None.
        pregrasp_offset: distance [m] the pre-grasp pose lies back along the approach axis (the distance
            the planner checked for collisions), or None: the protocol's `pregrasp_offset` (a planner that
            does not take a `PlanContext` says nothing, so the protocol's setting holds).
        planner: name of the planner that made it.
        planning_time_s: wall time of the planning call that produced it [s]
            (set by `manigrasp.planners.run.plan`).
        invalid: why this grasp cannot be executed ("" if it can): a grasp read from a file that
            cannot be placed (wrong hand, NaN, not a rotation). It is passed through unchecked and
            its trial is recorded as `invalid_grasp` with this detail, never dropped.
        joints: (2, hand.n_actuators) the grasp's own hand path of a dexterous hand, in actuator
            command units (joint angles [rad] of position servos, in `Hand.actuators` order): row 0
            the pre-shape (the command at the pre-grasp and while approaching), row 1 the squeeze
            target (the command at synergy 1, past contact). The protocol drives
            ctrl(s) = (1 - s) joints[0] + s joints[1] from s = `preshape`. None: the hand's own
            open/closed synergy. Parallel hands take None.
        source: where the grasp came from, for joining a trial back to it ("" if nothing to say): the `file`
            planner's "file grasp 7" (its index in the file). Its trial's detail begins with it
            (`manigrasp.bench.worker.run_trial`).
    """

    pose: np.ndarray
    score: float
    width: float | None = None
    preshape: float = 0.0
    contacts: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    contact_normals: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    contact_friction: np.ndarray | None = None
    epsilon_l1: float | None = None
    force_closure: bool | None = None
    min_friction: float | None = None
    pregrasp_offset: float | None = None
    planner: str = ""
    planning_time_s: float = 0.0
    invalid: str = ""
    joints: np.ndarray | None = None
    source: str = ""

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "pose", _readonly(self.pose))
        if self.joints is not None:
            set_(self, "joints", _readonly(self.joints))
        for name in ("contacts", "contact_normals"):
            set_(self, name, _readonly(np.asarray(getattr(self, name), dtype=float).reshape(-1, 3)))
        if self.contact_friction is not None:
            set_(self, "contact_friction", _readonly(np.asarray(self.contact_friction, dtype=float)))
        set_(self, "score", float(self.score))

    @classmethod
    def from_pos_quat(cls, pos: np.ndarray, quat: np.ndarray, score: float, **fields: object) -> GraspCandidate:
        """A candidate from a TCP position (3,) [m] and a unit quaternion (4,) (w, x, y, z).

        Raises:
            PlannerError: if `quat` is not a finite unit quaternion (within `geometry.RIGID_TOLERANCE`).
        """
        q = np.asarray(quat, dtype=float)
        defect = quaternion_defect(q)
        if defect is not None:
            raise PlannerError(f"grasp quaternion {q.tolist()} is not a finite unit quaternion (w, x, y, z): "
                               f"it {defect}")
        pose = pose_from_pos_quat(np.asarray(pos, dtype=float).reshape(1, 3), q[None])[0]
        return cls(pose=pose, score=score, **fields)  # type: ignore[arg-type]

    @property
    def position(self) -> np.ndarray:
        """(3,) TCP position in the world [m]."""
        return self.pose[:3, 3].copy()

    @property
    def approach(self) -> np.ndarray:
        """(3,) unit approach direction (TCP z) in the world."""
        return self.pose[:3, 2].copy()

    @property
    def closing(self) -> np.ndarray:
        """(3,) unit closing direction (TCP y) in the world."""
        return self.pose[:3, 1].copy()

    @property
    def pregrasp_pose(self) -> np.ndarray:
        """(4, 4) the pose `pregrasp_offset` back along the approach axis (`PREGRASP_OFFSET`, the standard
        protocol's, when the candidate names none)."""
        offset = PREGRASP_OFFSET if self.pregrasp_offset is None else self.pregrasp_offset
        return pregrasp_pose(self.pose, offset)


@runtime_checkable
class Planner(Protocol):
    """What every planner provides (ours and users')."""

    name: str
    needs: ObservationKind | tuple[ObservationKind, ...]
    # Optional: the `Hand.kind`s it plans for (absent: any); a run pairing it with another kind is told before
    # its trials run (they end `planner_error`, `bench.runner.validate`).
    # hand_kinds: tuple[str, ...]

    def plan(self, observation: Observation, hand: Hand, n: int,
             rng: np.random.Generator) -> Sequence[GraspCandidate]:
        """At most `n` candidates for `hand` on the observed object, best first."""
        ...
