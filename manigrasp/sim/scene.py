"""`Scene`: one compiled model per (object, hand), reused across trials by resetting.

    >>> scene = build_scene(hands.load("parallel_jaw"), asset)
    >>> scene.reset(mount=grasp_pose, synergy=0.0)   # hand open, TCP on the grasp pose
    >>> scene.step(500)

`Scene` is the only owner of `MjModel`/`MjData` (DESIGN.md); controllers take
its `base` view. Poses are (4, 4) homogeneous matrices in the world frame [m].
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import mujoco
import numpy as np

from manigrasp.errors import MeshError, SimulationError
from manigrasp.geometry import check_rigid, mat_to_quat, pose_matrix, quat_to_mat
from manigrasp.hands.base import Hand
from manigrasp.objects.poses import RestPose, stable_poses
from manigrasp.sim.compose import (
    BASE_JOINTS,
    BASE_SERVOS,
    HAND_PREFIX,
    OBJECT_BODY,
    TABLE_GEOM,
    HandFrames,
    ObjectSource,
    compile_spec,
    compose_spec,
    measure_hand,
    name_to_id,
    object_spec,
)
from manigrasp.sim.config import SceneConfig

SPAN_EPSILON = 1e-12  # an actuator whose open and closed commands differ by less does not move along a hand path

_BODY, _SITE, _JOINT, _ACT, _GEOM = (mujoco.mjtObj.mjOBJ_BODY, mujoco.mjtObj.mjOBJ_SITE, mujoco.mjtObj.mjOBJ_JOINT,
                                     mujoco.mjtObj.mjOBJ_ACTUATOR, mujoco.mjtObj.mjOBJ_GEOM)


@dataclass(frozen=True)
class FloatingBase:
    """The view of a scene that the controllers need (ids into `model`/`data`).

    Attributes:
        model, data: the scene's MuJoCo model and data (shared, not copied).
        tcp_site: id of the hand's TCP site.
        root_body: id of the hand's root body (it carries the six base joints).
        dofs: (6,) dof addresses of mount/tx..rz (slides, then hinges).
        actuators: (6,) ids of the base motors (ctrl = generalised force [N, N m]).
        anchor_joint: id of mount/rx, whose anchor (`data.xanchor`) is the
            rotation centre of the base: the open hand's centre of mass.
        mass: mass of the hand [kg].
        gravcomp: True if MuJoCo compensates the hand's weight (body gravcomp).
        servos: (6,) ids of the base servos (PD computed by MuJoCo; off until a controller engages them).
        tcp_in_root: (4, 4) pose of the TCP in the hand's root body frame (the base joints' frame).
    """

    model: mujoco.MjModel
    data: mujoco.MjData
    tcp_site: int
    root_body: int
    dofs: np.ndarray
    actuators: np.ndarray
    anchor_joint: int
    mass: float
    gravcomp: bool
    servos: np.ndarray
    tcp_in_root: np.ndarray

    def mount(self) -> np.ndarray:
        """(4, 4) world pose of the TCP at zero base joints (read from the root body's model pose)."""
        root = pose_matrix(self.model.body_pos[self.root_body], self.model.body_quat[self.root_body])
        return root @ self.tcp_in_root

    def release_servos(self) -> None:
        """Switch the base servos off (zero gains and command)."""
        self.model.actuator_gainprm[self.servos, 0] = 0.0
        self.model.actuator_biasprm[self.servos, :3] = 0.0
        self.data.ctrl[self.servos] = 0.0

    def diag_inertia(self) -> np.ndarray:
        """(6,) joint-space inertia of the base dofs at the current state: mass [kg] x3, then
        moments of inertia [kg m^2] of the hand about the three hinge axes (valid after `mj_forward`)."""
        full = np.zeros((self.model.nv, self.model.nv))
        mujoco.mj_fullM(self.model, self.data, full)
        return full[self.dofs, self.dofs].copy()


def position_servos(model: mujoco.MjModel, actuators: np.ndarray) -> np.ndarray:
    """(n,) bool: which of `actuators` (ids) are position servos, force kp (u - L) - kv dL/dt (MuJoCo's
    ``position``: fixed gain kp > 0, affine bias -kp L - kv dL/dt)."""
    ids = np.asarray(actuators, dtype=int)
    kp = model.actuator_gainprm[ids, 0]
    return (model.actuator_gaintype[ids] == mujoco.mjtGain.mjGAIN_FIXED) & (
        model.actuator_biastype[ids] == mujoco.mjtBias.mjBIAS_AFFINE) & (kp > 0) & np.isclose(
        model.actuator_biasprm[ids, 1], -kp) & (model.actuator_biasprm[ids, 0] == 0)


class Scene:
    """Table + object + hand on a floating base, compiled once (see `build_scene`)."""

    def __init__(self, hand: Hand, model: mujoco.MjModel, frames: HandFrames, config: SceneConfig) -> None:
        self.hand, self.model, self.config = hand, model, config
        self.data = mujoco.MjData(model)
        self._frames = frames
        self._root_in_tcp = np.linalg.inv(frames.tcp_in_root)
        self.root_body = name_to_id(model, _BODY, HAND_PREFIX + hand.root_body, "body")
        self.tcp_site = name_to_id(model, _SITE, HAND_PREFIX + hand.tcp_site, "site")
        self.table_geom = name_to_id(model, _GEOM, TABLE_GEOM, "geom")
        self.hand_actuators = np.array([name_to_id(model, _ACT, HAND_PREFIX + a, "actuator") for a in hand.actuators])
        base_joints = [name_to_id(model, _JOINT, j, "joint") for j in BASE_JOINTS]
        self.base = FloatingBase(
            model=model, data=self.data, tcp_site=self.tcp_site, root_body=self.root_body,
            dofs=model.jnt_dofadr[base_joints].copy(), actuators=np.array([name_to_id(model, _ACT, j, "actuator")
                                                                          for j in BASE_JOINTS]),
            anchor_joint=base_joints[3], mass=float(model.body_subtreemass[self.root_body]),
            gravcomp=config.hand_gravcomp,
            servos=np.array([name_to_id(model, _ACT, s, "actuator") for s in BASE_SERVOS]),
            tcp_in_root=frames.tcp_in_root.copy())
        self.base_qpos = model.jnt_qposadr[base_joints].copy()
        self.hand_bodies = np.flatnonzero(model.body_rootid == self.root_body)
        self.finger_of_body = self._finger_map()
        self._open_qpos = self._hand_open_qpos()
        self.object_body = mujoco.mj_name2id(model, _BODY, OBJECT_BODY)
        self.object_geoms = self._object_geoms()
        self.geom_is_hand = np.isin(model.geom_bodyid, self.hand_bodies)
        self.geom_is_object = np.zeros(model.ngeom, bool)
        self.geom_is_object[self.object_geoms] = True
        self.geom_finger = self.finger_of_body[model.geom_bodyid]
        self._object_qpos = self._object_free_qpos()
        self.rest = self._rest_pose()
        self.object_rest_height = self.rest.height
        self.mount = np.eye(4)
        self.set_hand_path()
        self.reset()

    # ----------------------------------------------------------------- ids
    def _finger_map(self) -> np.ndarray:
        """(nbody,) index into `hand.finger_bodies` of each body's finger, -1 if none."""
        fingers = {name_to_id(self.model, _BODY, HAND_PREFIX + f, "body"): i
                   for i, f in enumerate(self.hand.finger_bodies)}
        out = np.full(self.model.nbody, -1)
        for body in self.hand_bodies:
            b = int(body)
            while b != self.root_body and b not in fingers:
                b = int(self.model.body_parentid[b])
            out[body] = fingers.get(b, -1)
        return out

    @functools.cached_property
    def distal_body(self) -> np.ndarray:
        """(nbody,) True for the hand bodies on a finger's distal phalanx: the nearest hinge up from the body
        (its own included) moves no other hinge (the last joint of its chain); a body fixed to the palm is not.
        Hinges only: a compliant pad's elements ride on slide joints (`manigrasp.hands.pads`) and belong to the
        phalanx they sit on."""
        m = self.model
        out = np.zeros(m.nbody, bool)
        hinge = m.jnt_type == mujoco.mjtJoint.mjJNT_HINGE
        has_joint = np.bincount(m.jnt_bodyid[hinge], minlength=m.nbody) > 0
        below = np.zeros(m.nbody, bool)  # a joint in the body's subtree, below the body itself
        for b in range(m.nbody - 1, 0, -1):  # children come after their parents
            parent = int(m.body_parentid[b])
            below[parent] |= below[b] or has_joint[b]
        for body in self.hand_bodies:
            b = int(body)
            while b != self.root_body and not has_joint[b]:
                b = int(m.body_parentid[b])
            out[body] = b != self.root_body and self.finger_of_body[body] >= 0 and not below[b]
        return out

    @functools.cached_property
    def actuator_fingers(self) -> np.ndarray:
        """(n_act,) index into `hand.finger_bodies` of the finger each hand actuator moves, -1 if none or several:
        the finger of its joint (joint transmission) or of every joint its tendon spans (a finger's tendon).
        Computed on first use (`control.FingerHold` asks)."""
        m = self.model
        out = np.full(len(self.hand_actuators), -1)
        for i, a in enumerate(self.hand_actuators):
            kind, target = int(m.actuator_trntype[a]), int(m.actuator_trnid[a, 0])
            if kind in (mujoco.mjtTrn.mjTRN_JOINT, mujoco.mjtTrn.mjTRN_JOINTINPARENT):
                joints = [target]
            elif kind == mujoco.mjtTrn.mjTRN_TENDON:
                wraps = range(m.tendon_adr[target], m.tendon_adr[target] + m.tendon_num[target])
                joints = [int(m.wrap_objid[w]) for w in wraps if m.wrap_type[w] == mujoco.mjtWrap.mjWRAP_JOINT]
            else:
                continue
            fingers = {int(self.finger_of_body[m.jnt_bodyid[j]]) for j in joints}
            if len(fingers) == 1:
                out[i] = fingers.pop()
        return out

    def _hand_open_qpos(self) -> list[tuple[int, np.ndarray]]:
        pairs = []
        for name, value in self._frames.open_qpos.items():
            j = name_to_id(self.model, _JOINT, HAND_PREFIX + name, "joint")
            pairs.append((int(self.model.jnt_qposadr[j]), value))
        return pairs

    def _object_geoms(self) -> np.ndarray:
        if self.object_body < 0:
            return np.zeros(0, int)
        m = self.model
        own = m.geom_bodyid == self.object_body
        return np.flatnonzero(own & ((m.geom_contype != 0) | (m.geom_conaffinity != 0)))

    def _object_free_qpos(self) -> int | None:
        if self.object_body < 0 or self.model.body_jntnum[self.object_body] == 0:
            return None
        j = self.model.body_jntadr[self.object_body]
        if self.model.jnt_type[j] != mujoco.mjtJoint.mjJNT_FREE:
            raise SimulationError("the object's body must have a free joint or no joint")
        return int(self.model.jnt_qposadr[j])

    def _object_points(self) -> np.ndarray:
        """(n, 3) points of the object's collision geoms in the object frame [m] (mesh vertices, box corners)."""
        return collision_points(self.model, self.object_geoms)

    def _rest_pose(self) -> RestPose:
        """The object's resting orientation and height, as `config.rest` chooses."""
        points = self._object_points()
        if self.config.rest in ("most_stable", "stable_k") and len(points) >= 4:
            poses = stable_poses(points)
            if self.config.rest_index >= len(poses):
                raise SimulationError(f"rest_index {self.config.rest_index}: the object has only {len(poses)} "
                                      "stable poses")
            return poses[self.config.rest_index]
        height = -float(points[:, 2].min()) if len(points) else 0.0
        return RestPose(rotation=np.eye(3), height=height, probability=1.0)

    # ------------------------------------------------------------- state
    def reset(self, mount: np.ndarray | None = None, object_pose: np.ndarray | None = None,
              synergy: float = 0.0) -> None:
        """Reset the state: hand open at `mount`, object at `object_pose`, zero velocities.

        Args:
            mount: (4, 4) TCP pose at zero base joints (default: the current mount).
            object_pose: (4, 4) object pose (default: resting on the table at x = y = 0).
            synergy: hand command in [0, 1] (0 open) along `hand_path`; the joints start at the open shape.

        The base motors and servos are off afterwards until a controller commands or engages them.
        """
        mujoco.mj_resetData(self.model, self.data)
        self.base.release_servos()
        if mount is not None:
            self.set_mount(mount)
        for adr, value in self._open_qpos:
            self.data.qpos[adr:adr + len(value)] = value
        if self.object_body >= 0:
            self.set_object_pose(object_pose if object_pose is not None else self.object_rest_pose())
        self.set_synergy(synergy)
        mujoco.mj_forward(self.model, self.data)

    def set_mount(self, mount: np.ndarray) -> None:
        """Move the base so that zero base joints put the TCP at `mount` (4, 4); no recompile.

        Edits the root body's `body_pos`/`body_quat`; call `reset` or `forward` afterwards.
        """
        mount = check_rigid(mount, "mount")
        root = mount @ self._root_in_tcp
        self.model.body_pos[self.root_body] = root[:3, 3]
        self.model.body_quat[self.root_body] = mat_to_quat(root[:3, :3])
        self.mount = mount.copy()

    def object_rest_pose(self, xy: tuple[float, float] = (0.0, 0.0)) -> np.ndarray:
        """(4, 4) pose of the object resting on the table at `xy` [m], in the orientation that
        `config.rest` chooses: as in its file ("file") or its most stable pose ("most_stable")."""
        return self.rest.matrix(xy)

    def set_object_pose(self, pose: np.ndarray) -> None:
        """Place the object at `pose` (4, 4) with zero velocity (a fixed object: edit the model)."""
        pose = check_rigid(pose, "object pose")
        quat = mat_to_quat(pose[:3, :3])
        if self._object_qpos is None:
            self.model.body_pos[self.object_body], self.model.body_quat[self.object_body] = pose[:3, 3], quat
            return
        adr = self._object_qpos
        self.data.qpos[adr:adr + 3], self.data.qpos[adr + 3:adr + 7] = pose[:3, 3], quat
        dof = self.model.jnt_dofadr[self.model.body_jntadr[self.object_body]]
        self.data.qvel[dof:dof + 6] = 0.0

    @property
    def hand_path(self) -> tuple[np.ndarray, np.ndarray]:
        """(open (n_act,), closed (n_act,)) actuator commands at synergy 0 and 1 (read-only copies)."""
        return self._path[0].copy(), self._path[1].copy()

    def set_hand_path(self, open_ctrl: np.ndarray | None = None, closed_ctrl: np.ndarray | None = None) -> None:
        """The straight line of hand commands the synergy drives: ctrl(s) = (1 - s) open + s closed.

        A grasp with its own joint configuration sets its pre-shape and squeeze rows (n_act,) here; no
        arguments (or None): the hand's own `open_ctrl` / `closed_ctrl`. It stays until set again (the
        protocol sets it at every reset of a trial and gives the hand's own back at its end).
        """
        n = self.hand.n_actuators
        path = (self.hand.open_ctrl if open_ctrl is None else open_ctrl,
                self.hand.closed_ctrl if closed_ctrl is None else closed_ctrl)
        rows = [np.array(row, dtype=float) for row in path]
        if any(r.shape != (n,) or not np.all(np.isfinite(r)) for r in rows):
            raise ValueError(f"a hand path needs two finite rows of {n} actuator commands, got shapes "
                             f"{rows[0].shape}, {rows[1].shape}")
        for row in rows:
            row.setflags(write=False)
        self._path = (rows[0], rows[1])
        self._reach_lead = self._servo_leads()

    def hand_ctrlrange(self) -> np.ndarray:
        """(n_act, 2) [lower, upper] command range of the hand actuators (NaN where not limited)."""
        acts = self.hand_actuators
        limited = self.model.actuator_ctrllimited[acts].astype(bool)
        return np.where(limited[:, None], self.model.actuator_ctrlrange[acts], np.nan)

    def set_synergy(self, s: float) -> None:
        """Hand actuator commands of synergy `s` in [0, 1] (0 open, 1 closed) along `hand_path`."""
        s = float(np.clip(s, 0.0, 1.0))
        self.data.ctrl[self.hand_actuators] = (1.0 - s) * self._path[0] + s * self._path[1]

    def finger_synergies(self) -> np.ndarray:
        """(m,) where each hand actuator that moves along `hand_path` is: (length - open) / (closed - open) of
        its transmission, clipped to [0, 1] (a blocked finger stays below its command). Actuators whose open
        and closed commands are equal (fixed pre-shape joints: the Allegro's spread and thumb rotation, the
        five-finger hands' thumb rotation) are left out: they are neither open nor closed."""
        open_ctrl, closed_ctrl = self._path
        span = closed_ctrl - open_ctrl
        moving = np.abs(span) > SPAN_EPSILON
        length = self.data.actuator_length[self.hand_actuators]
        return np.clip((length[moving] - open_ctrl[moving]) / span[moving], 0.0, 1.0)

    def hand_synergy(self) -> float:
        """Where the fingers are along `hand_path`, as a synergy in [0, 1]: the mean of `finger_synergies`
        (1 for a path on which nothing moves)."""
        frac = self.finger_synergies()
        return float(frac.mean()) if len(frac) else 1.0

    def closing_reach(self) -> float:
        """The furthest synergy command that drives no moving finger's servo past its force limit: the
        smallest over the fingers that move along `hand_path` of where the finger is (`finger_synergies`)
        plus the command lead that brings its position servo to its force limit, f_max / (kp |closed -
        open|): 0.26 of the synergy for the five-finger hands' fingers (0.6 N m, 0.5 N m/rad, 4.7 rad), 0.30
        for the Allegro's. Further ahead, the finger that stands there pushes no harder, and a free finger
        lands on the object with its servo saturated. Actuators that are not force-limited position servos
        (`position_servos`) are left out; `hand_synergy` if none is one. (The grip loop asks at every control
        tick: the leads, fixed for a path, are computed when the path is set.)"""
        if self._reach_lead is None:
            return 1.0
        servo, lead = self._reach_lead
        if not servo.any():
            return self.hand_synergy()
        return float(np.min(self.finger_synergies()[servo] + lead))

    def _servo_leads(self) -> tuple[np.ndarray, np.ndarray] | None:
        """For `closing_reach`, of the actuators that move along `hand_path`: which are force-limited position
        servos (mask) and, for those, the command lead to their force limit, max(0, f_max / (kp |span|));
        None when nothing moves."""
        open_ctrl, closed_ctrl = self._path
        span = closed_ctrl - open_ctrl
        moving = np.abs(span) > SPAN_EPSILON
        if not moving.any():
            return None
        m, ids = self.model, self.hand_actuators[moving]
        kp = m.actuator_gainprm[ids, 0]
        servo = position_servos(m, ids) & m.actuator_forcelimited[ids].astype(bool)
        limit = np.where(span[moving] > 0, m.actuator_forcerange[ids, 1], -m.actuator_forcerange[ids, 0])
        lead = limit[servo] / (kp[servo] * np.abs(span[moving][servo]))
        return servo, np.maximum(lead, 0.0)

    def actuator_leads(self) -> np.ndarray:
        """(n_act,) each hand actuator's command lead to its force limit along `hand_path`, in synergy units:
        f_max / (kp |closed - open|) in the closing direction (as `closing_reach` uses per finger; a per-finger
        close, `control.FingerClose`, per actuator); NaN for an actuator that does not move along the path or is
        not a force-limited position servo (`position_servos`)."""
        open_ctrl, closed_ctrl = self._path
        span = closed_ctrl - open_ctrl
        m, ids = self.model, self.hand_actuators
        moving = np.abs(span) > SPAN_EPSILON
        servo = moving & position_servos(m, ids) & m.actuator_forcelimited[ids].astype(bool)
        limit = np.where(span > 0, m.actuator_forcerange[ids, 1], -m.actuator_forcerange[ids, 0])
        kp = m.actuator_gainprm[ids, 0]
        with np.errstate(divide="ignore", invalid="ignore"):
            lead = np.maximum(limit / (kp * np.abs(span)), 0.0)
        return np.where(servo, lead, np.nan)

    def forward(self) -> None:
        """`mj_forward`: recompute positions, contacts and forces of the current state."""
        mujoco.mj_forward(self.model, self.data)

    def step(self, n: int = 1) -> None:
        """Advance `n` steps of `model.opt.timestep` with the current controls (one call into MuJoCo)."""
        if n > 0:
            mujoco.mj_step(self.model, self.data, nstep=n)

    # ------------------------------------------------------------ read-out
    @property
    def time(self) -> float:
        """Simulated time since the last reset [s]."""
        return float(self.data.time)

    def tcp_pose(self) -> np.ndarray:
        """(4, 4) world pose of the TCP."""
        pose = np.eye(4)
        pose[:3, :3] = self.data.site_xmat[self.tcp_site].reshape(3, 3)
        pose[:3, 3] = self.data.site_xpos[self.tcp_site]
        return pose

    def object_pose(self) -> np.ndarray:
        """(4, 4) world pose of the object frame (its centre of mass for an ObjectAsset)."""
        if self.object_body < 0:
            raise SimulationError("this scene has no object")
        return pose_matrix(self.data.xpos[self.object_body], self.data.xquat[self.object_body])

    def object_mass(self) -> float:
        """Mass of the object [kg] (0 without an object)."""
        return float(self.model.body_mass[self.object_body]) if self.object_body >= 0 else 0.0

    def warnings(self) -> dict[str, int]:
        """MuJoCo warnings raised since the last reset: name -> count (empty if none)."""
        return {mujoco.mjtWarning(i).name: int(w.number) for i, w in enumerate(self.data.warning) if w.number}

    def is_finite(self) -> bool:
        """True if positions, velocities and accelerations are all finite."""
        d = self.data
        return bool(np.isfinite(d.qpos).all() and np.isfinite(d.qvel).all() and np.isfinite(d.qacc).all())


def collision_points(model: mujoco.MjModel, geoms: np.ndarray) -> np.ndarray:
    """(n, 3) points of `geoms` in their body's frame [m]: mesh vertices, or the corners of a primitive's box."""
    out = [np.zeros((0, 3))]
    for g in geoms:
        if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH:
            mesh = model.geom_dataid[g]
            pts = model.mesh_vert[model.mesh_vertadr[mesh]:model.mesh_vertadr[mesh] + model.mesh_vertnum[mesh]]
        else:
            center, half = model.geom_aabb[g, :3], model.geom_aabb[g, 3:]
            corners = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T
            pts = center + corners * half
        out.append(pts @ quat_to_mat(model.geom_quat[g]).T + model.geom_pos[g])
    return np.concatenate(out)


def object_stable_poses(obj: ObjectSource) -> list[RestPose]:
    """The stable poses of an object (`manigrasp.objects.poses.stable_poses`, most probable first) from the
    same collision geometry a scene uses, compiling the object's MJCF alone (no hand, no table); [] if its
    geometry has no 3-D hull. ``rest: stable_k`` runs the first `rest_k` of them."""
    model = compile_spec(object_spec(obj), "object")
    body = name_to_id(model, _BODY, OBJECT_BODY, "body")
    geoms = np.flatnonzero((model.geom_bodyid == body) & ((model.geom_contype != 0) | (model.geom_conaffinity != 0)))
    points = collision_points(model, geoms)
    try:
        return stable_poses(points) if len(points) >= 4 else []
    except MeshError:
        return []


def build_scene(hand: Hand | str, obj: ObjectSource | None = None, config: SceneConfig | None = None) -> Scene:
    """Compile table + `obj` + `hand` on a floating base into a `Scene`.

    Args:
        hand: a `Hand` or a hand registry name.
        obj: an `ObjectAsset`, the path of an object MJCF (a body named
            ``object`` with a free joint, or no joint for a fixed object), an
            `MjSpec` of one, or None for no object.
        config: physics and scene parameters (default: the standard protocol).
    """
    if isinstance(hand, str):
        from manigrasp.hands import load

        hand = load(hand)
    config = config or SceneConfig()
    frames = measure_hand(hand, config.open_settle_time)
    model = compile_spec(compose_spec(hand, frames, obj, config), f"scene of hand {hand.name!r}")
    return Scene(hand, model, frames, config)
