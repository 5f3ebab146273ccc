"""A grasp set in memory: TCP poses in an object's frame, jaw widths, pre-shapes, scores and labels.

Pure data and math (no file I/O, no mujoco). Readers (`native`, `acronym`) check a file's
structure and raise `GraspFileError` naming the problem; what they cannot decide (a NaN pose,
a rotation that is not one, the wrong hand) is left in the set and decided per grasp by
`placement_defect` when the set is placed on an object: that grasp's trial is `invalid_grasp`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from manigrasp.errors import ManigraspError
from manigrasp.geometry import rigid_defect

Frame = Literal["object", "mesh"]
FRAMES: tuple[str, ...] = ("object", "mesh")


class GraspFileError(ManigraspError, ValueError):
    """A grasp file that cannot be read: missing keys, wrong shapes, non-finite values where none may be."""


@dataclass(frozen=True)
class ObjectRef:
    """The object a grasp set was made for, as the file names it.

    Attributes:
        name: object name (a shipped name such as "025_mug", or the name given to a mesh), or None.
        mesh: path of its mesh file (relative paths are relative to the grasp file), or None.
        scale: factor applied to the mesh file's vertices (ACRONYM's ``object/scale``).
        mass: [kg], or None.
        built: `mesh` is the built visual mesh of the manigrasp object `name` (an ACRONYM file written by
            `manigrasp label`, or a native file converted from one): its frame is manigrasp's object frame, and
            the object is resolved by `name` (a shipped object is built by its name, not from the cached mesh,
            which is named for the cache).
    """

    name: str | None = None
    mesh: str | None = None
    scale: float = 1.0
    mass: float | None = None
    built: bool = False


LABELLED_UNDER_KEYS = ("protocol", "scene")


def check_labelled_under(value: Any, where: str) -> dict[str, Any]:
    """`GraspSet.labelled_under` checked: a mapping of ``protocol`` (``{"name": text, "params": {...}}``) and
    ``scene`` (a mapping of scene parameters), either optional; `GraspFileError` naming what is wrong. The values
    themselves are checked where they are used (`manigrasp evaluate` builds its config from them)."""
    if not isinstance(value, Mapping):
        raise GraspFileError(f"{where}: labelled_under must be an object with protocol and scene, got {value!r}")
    extra = sorted(set(value) - set(LABELLED_UNDER_KEYS))
    if extra:
        raise GraspFileError(f"{where}: labelled_under: unknown key {extra[0]!r}; valid keys: "
                             f"{', '.join(LABELLED_UNDER_KEYS)}")
    out: dict[str, Any] = {}
    protocol = value.get("protocol")
    if protocol is not None:
        if not isinstance(protocol, Mapping) or not isinstance(protocol.get("name"), str) \
                or not isinstance(protocol.get("params", {}), Mapping) or set(protocol) - {"name", "params"}:
            raise GraspFileError(f"{where}: labelled_under: protocol must be {{name: text, params: {{...}}}}, got "
                                 f"{protocol!r}")
        out["protocol"] = {"name": protocol["name"], "params": dict(protocol.get("params", {}))}
    scene = value.get("scene")
    if scene is not None:
        if not isinstance(scene, Mapping) or not all(isinstance(k, str) for k in scene):
            raise GraspFileError(f"{where}: labelled_under: scene must be a mapping of scene parameters, got "
                                 f"{scene!r}")
        out["scene"] = dict(scene)
    return out


def labelled_under_from_text(text: str, where: str) -> Any:
    """`GraspSet.labelled_under` as a file holds it in one string (NPZ, ACRONYM's HDF5): its JSON, parsed;
    `GraspFileError` if it is not JSON (the set checks the mapping, `check_labelled_under`)."""
    import json

    try:
        return json.loads(text)
    except ValueError as exc:
        raise GraspFileError(f"{where}: 'labelled_under' is not JSON text ({exc})") from exc


@dataclass(frozen=True, eq=False)
class GraspSet:
    """Grasps of one hand kind on one object.

    Attributes:
        poses: (n, 4, 4) TCP poses (z approach, y closing) in the object's frame [m]; may hold
            NaN or non-rotations (then that grasp is `invalid_grasp`, see `placement_defect`).
        widths: (n,) jaw opening at contact [m]; NaN: not given; +-inf: given but not a finite number (a JSON
            width of NaN or +-Infinity): that grasp is `invalid_grasp` (see `placement_defect`).
        preshapes: (n,) the hand's pre-shape synergy in [0, 1] (0 = open): a dexterous hand's
            joint configuration as manigrasp drives it.
        scores: (n,) finite ranking scores (higher first).
        frame: "object": manigrasp's object frame (origin at the centre of mass, axes of the mesh);
            "mesh": the frame of `object.mesh` scaled by `object.scale` (ACRONYM's convention).
        hand: the hand the grasps were made for, or None (any hand of `hand_kind`).
        hand_kind: "parallel", "dexterous" or None (not stated).
        object: the object, as the file names it.
        labels: per-grasp columns (n,) of a labelled set: "status", "success", metrics...
        source: where the set was read from (for messages).
        joints: (n, 2, n_act) each grasp's own hand path of a dexterous hand (`GraspCandidate.joints`:
            row 0 pre-shape, row 1 squeeze target, actuator commands), or None (every grasp uses the
            hand's own path). An all-NaN (2, n_act) entry: that grasp uses the hand's own path.
        labelled_under: what a labelled set's labels were measured under, or None (not recorded):
            ``{"protocol": {"name": ..., "params": {...}}, "scene": {...}}``, the scene as the scene parameters
            that differ from their defaults (`manigrasp label` writes it; `manigrasp evaluate` runs under it).
    """

    poses: np.ndarray
    widths: np.ndarray
    preshapes: np.ndarray
    scores: np.ndarray
    frame: Frame = "object"
    hand: str | None = None
    hand_kind: str | None = None
    object: ObjectRef = field(default_factory=ObjectRef)
    labels: Mapping[str, np.ndarray] = field(default_factory=dict)
    source: str = ""
    joints: np.ndarray | None = None
    labelled_under: Mapping[str, Any] | None = None

    def __post_init__(self) -> None:
        where = self.source or "grasp set"
        poses = np.asarray(self.poses, dtype=float)
        if poses.ndim != 3 or poses.shape[1:] != (4, 4):
            raise GraspFileError(f"{where}: poses must be (n, 4, 4), got shape {poses.shape}")
        n = len(poses)
        for name in ("widths", "preshapes", "scores"):
            value = np.asarray(getattr(self, name), dtype=float)
            if value.shape != (n,):
                raise GraspFileError(f"{where}: {name} must have shape ({n},) (one per grasp), got {value.shape}")
            object.__setattr__(self, name, value)
        bad = np.flatnonzero(~np.isfinite(self.scores))
        if bad.size:
            raise GraspFileError(f"{where}: score of grasp {bad[0]} is {self.scores[bad[0]]} (scores rank the "
                                 "grasps: give finite scores, or none)")
        if self.frame not in FRAMES:
            raise GraspFileError(f"{where}: frame must be one of {', '.join(FRAMES)}, got {self.frame!r}")
        if self.hand_kind is not None:
            from manigrasp.hands.base import HAND_KINDS  # the hands' own list (imported when a set names a kind)

            if self.hand_kind not in HAND_KINDS:
                raise GraspFileError(f"{where}: hand_kind must be one of {', '.join(HAND_KINDS)}, got "
                                     f"{self.hand_kind!r}")
        labels = {k: np.asarray(v) for k, v in self.labels.items()}
        for key, value in labels.items():
            if value.shape[:1] != (n,):
                raise GraspFileError(f"{where}: label {key!r} must have one value per grasp ({n}), "
                                     f"got shape {value.shape}")
        scale, mass = self.object.scale, self.object.mass
        if not (np.isfinite(scale) and scale > 0):
            raise GraspFileError(f"{where}: object scale must be a finite number > 0, got {scale}")
        if mass is not None and not (np.isfinite(mass) and mass > 0):
            raise GraspFileError(f"{where}: object mass must be a finite number > 0 [kg], got {mass}")
        object.__setattr__(self, "poses", poses)
        object.__setattr__(self, "labels", labels)
        if self.joints is not None:
            joints = np.asarray(self.joints, dtype=float)
            if joints.ndim != 3 or joints.shape[:2] != (n, 2):
                raise GraspFileError(f"{where}: joints must be (n, 2, n_actuators) with n = {n} (a pre-shape and "
                                     f"a squeeze row per grasp), got shape {joints.shape}")
            object.__setattr__(self, "joints", joints)
        if self.labelled_under is not None:
            object.__setattr__(self, "labelled_under", check_labelled_under(self.labelled_under, where))

    def grasp_joints(self, index: int) -> np.ndarray | None:
        """(2, n_act) the own hand path of grasp `index`, or None (the hand's own path)."""
        if self.joints is None or np.all(np.isnan(self.joints[index])):
            return None
        return self.joints[index]

    def __len__(self) -> int:
        return len(self.poses)

    def ranked(self) -> np.ndarray:
        """(n,) grasp indices by score, best first (stable: equal scores keep file order)."""
        return np.argsort(-self.scores, kind="stable")


def rotation_defect(pose: np.ndarray) -> str | None:
    """Why the (4, 4) `pose` is not a finite rigid transform (`manigrasp.geometry.rigid_defect`, the tolerance
    every layer uses), or None."""
    defect = rigid_defect(pose)
    return None if defect is None else f"its pose {defect}"


def placement_defect(grasps: GraspSet, index: int, hand_name: str, hand_kind: str, max_width: float,
                     transfer: bool = False, n_actuators: int | None = None) -> str | None:
    """Why grasp `index` of `grasps` cannot be executed by the hand `hand_name` (of `hand_kind`, opening at
    most `max_width` [m]), as a sentence, or None.

    `transfer`: accept a set made for another hand of the same kind (the TCP convention is the same
    for every hand of a kind, so a parallel-jaw set can run on any parallel jaw). A set that names its hand but
    not its kind is of that hand's kind when the hand is registered (`manigrasp.hands.registry.registered_kind`);
    of an unknown hand, of any kind. `n_actuators`: the hand's, which a grasp's joints must match
    ((2, n_actuators)); None: not checked.
    """
    prefix = f"grasp {index} of {grasps.source or 'the grasp set'}"
    kind, named = grasps.hand_kind, ""
    if kind is None and grasps.hand is not None and grasps.hand != hand_name:
        from manigrasp.hands.registry import registered_kind

        kind, named = registered_kind(grasps.hand), f" (made for hand {grasps.hand!r})"
    if kind is not None and kind != hand_kind:
        return f"{prefix} is a {kind} grasp{named}; hand {hand_name!r} is {hand_kind}"
    if grasps.hand is not None and grasps.hand != hand_name and not transfer:
        return f"{prefix} was made for hand {grasps.hand!r}, not {hand_name!r} (planner param transfer: true runs it)"
    problem = rotation_defect(grasps.poses[index])
    if problem:
        return f"{prefix}: {problem}"
    preshape, width = grasps.preshapes[index], grasps.widths[index]
    if not (np.isfinite(preshape) and 0.0 <= preshape <= 1.0):
        return f"{prefix}: pre-shape {preshape} is outside [0, 1]"
    if np.isinf(width):  # NaN: not given
        return f"{prefix}: width is given but not a finite number"
    if np.isfinite(width) and not 0.0 <= width <= max_width + 1e-9:
        return f"{prefix}: width {width:.4g} m is outside [0, {max_width:.4g}] m, the opening of {hand_name!r}"
    joints = grasps.grasp_joints(index)
    if joints is not None:
        if hand_kind != "dexterous":
            return f"{prefix} has joints, but hand {hand_name!r} is a {hand_kind} hand (joints are for dexterous hands)"
        if n_actuators is not None and joints.shape != (2, n_actuators):
            return (f"{prefix}: joints have shape {joints.shape}; hand {hand_name!r} needs (2, {n_actuators}) "
                    "(pre-shape and squeeze rows of its actuator commands)")
        if not np.all(np.isfinite(joints)):
            return f"{prefix}: joints contain NaN or inf"
    return None


def translation(offset: np.ndarray) -> np.ndarray:
    """(4, 4) the pure translation by `offset` (3,) [m]."""
    out = np.eye(4)
    out[:3, 3] = offset
    return out
