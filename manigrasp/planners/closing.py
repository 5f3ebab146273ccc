"""Kinematic closing of a hand: the path of its joints from open to closed, and where it stops on an object.

`closing_path` simulates the hand alone (no gravity, nothing to touch) driven
from its open to its closed command until its joints stop, and resamples the joint trajectory into
`steps` shapes, evenly spaced in joint space. `close_on_object` then sweeps a
placed hand along that path, finger by finger: a finger (every joint in its
body's subtree) stops at the first shape where it touches the object or the
table; the others keep closing. The contacts where fingers stopped are the
planned contacts.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from manigrasp.hands.base import Hand
from manigrasp.planners.collision import HandProbe

SETTLE_TIME = 0.5  # [s] driven open before closing
CLOSE_TIME = 8.0  # [s] longest free close (the robosuite hands' damped fingers take ~4 s)
STILL_SPEED = 1e-3  # [rad/s or m/s] the free close has ended when no joint moves faster


@dataclass(frozen=True)
class ClosingPath:
    """Joint shapes from open (row 0) to closed (last row).

    Attributes:
        joints: names of the hand's 1-dof joints (unprefixed).
        shapes: (steps + 1, n_joints) joint positions [m or rad].
    """

    joints: tuple[str, ...]
    shapes: np.ndarray


def closing_path(hand: Hand, steps: int) -> ClosingPath:
    """The hand's free closing motion resampled into `steps` + 1 shapes (module docstring).

    The root body floats (a free joint, gravity off), as in a scene: a root welded to the world
    would not filter contacts between the palm and its own fingers (MuJoCo filters parent-child
    contacts only for moving parents), and the palm would push the fingers off their path.
    """
    spec = hand.build_spec()
    spec.body(hand.root_body).add_freejoint()
    model = spec.compile()
    model.opt.gravity[:] = 0.0
    data = mujoco.MjData(model)
    act = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, a) for a in hand.actuators]
    one_dof = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))
    joints = [j for j in range(model.njnt) if int(model.jnt_type[j]) in one_dof]
    adr = model.jnt_qposadr[joints]
    data.ctrl[act] = hand.open_ctrl
    for _ in range(int(round(SETTLE_TIME / model.opt.timestep))):
        mujoco.mj_step(model, data)
    data.ctrl[act] = hand.closed_ctrl
    trajectory = [data.qpos[adr].copy()]
    dof = model.jnt_dofadr[joints]
    for step in range(int(round(CLOSE_TIME / model.opt.timestep))):
        mujoco.mj_step(model, data)
        trajectory.append(data.qpos[adr].copy())
        if step * model.opt.timestep > SETTLE_TIME and np.max(np.abs(data.qvel[dof])) < STILL_SPEED:
            break
    path = np.array(trajectory)
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(path, axis=0), axis=1))])
    targets = np.linspace(0.0, arc[-1], steps + 1)
    shapes = np.stack([np.interp(targets, arc, path[:, j]) for j in range(path.shape[1])], axis=1)
    return ClosingPath(joints=tuple(model.joint(j).name for j in joints), shapes=shapes)


@dataclass(frozen=True)
class Closure:
    """Where a closing hand touched the object.

    Attributes:
        positions: (k, 3) contact points [m] (one per touching hand geom).
        normals: (k, 3) unit normals pointing into the object.
        fingers: (k,) index into `hand.finger_bodies` of each contact's finger.
        n_fingers: number of distinct fingers touching the object.
        friction: (k, 2) sliding [-] and torsional [m] friction of each contact's hand geom as the probe compiled
            it (None: not recorded).
    """

    positions: np.ndarray
    normals: np.ndarray
    fingers: np.ndarray
    n_fingers: int
    friction: np.ndarray | None = None


class FingerSweep:
    """Sweeps the fingers of a probe's hand along a closing path (see `close_on_object`)."""

    def __init__(self, probe: HandProbe, path: ClosingPath) -> None:
        scene = probe.scene
        address = probe.hand_qpos_addresses()
        model = scene.model
        self.probe, self.path = probe, path
        columns, addresses, fingers = [], [], []
        for col, name in enumerate(path.joints):
            if name not in address:
                continue
            joint = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, "hand/" + name)
            columns.append(col)
            addresses.append(address[name])
            fingers.append(int(scene.finger_of_body[model.jnt_bodyid[joint]]))
        self.columns, self.addresses = np.array(columns, int), np.array(addresses, int)
        self.joint_finger = np.array(fingers, int)
        self.n_fingers = len(scene.hand.finger_bodies)
        self.finger_of_geom = scene.finger_of_body[model.geom_bodyid]

    def close(self, pos: np.ndarray, quat: np.ndarray) -> Closure:
        """Close the hand with its root at `pos` (3,), `quat` (4,); the probe is restored afterwards."""
        probe, shapes = self.probe, self.path.shapes[:, self.columns]
        moving = np.ones(self.n_fingers, bool)
        found_pos, found_normal, found_finger, found_geom = [], [], [], []
        qpos = probe.scene.data.qpos
        for shape in shapes[1:]:
            joint_moves = (self.joint_finger < 0) | moving[np.maximum(self.joint_finger, 0)]
            qpos[self.addresses[joint_moves]] = shape[joint_moves]
            probe.place(pos, quat)
            c_pos, c_normal, c_geom = probe.object_contacts()
            finger = self.finger_of_geom[c_geom]
            hit = (finger >= 0) & moving[np.maximum(finger, 0)]
            for g in np.unique(c_geom[hit]):
                row = np.flatnonzero(c_geom == g)[0]
                found_pos.append(c_pos[row])
                found_normal.append(c_normal[row])
                found_finger.append(int(finger[row]))
                found_geom.append(int(g))
            table_fingers = self.finger_of_geom[probe.table_touched()]
            moving[finger[hit]] = False
            moving[table_fingers[table_fingers >= 0]] = False
            if not moving.any():
                break
        probe.restore()
        fingers = np.array(found_finger, int)
        friction = probe.scene.model.geom_friction[np.array(found_geom, int), :2].reshape(-1, 2).copy()
        return Closure(positions=np.array(found_pos).reshape(-1, 3), normals=np.array(found_normal).reshape(-1, 3),
                       fingers=fingers, n_fingers=len(np.unique(fingers)), friction=friction)
