"""Exact hand collision tests in MuJoCo: the hand's real collision geometry vs the object and the table.

`HandProbe` compiles one scene (table + object at its observed pose + the hand
on its mount, through `manigrasp.sim.build_scene`) and then, for each pose,
only moves the hand's mount and runs MuJoCo's kinematics and collision
detection (no dynamics, no recompilation) for hand-object and hand-table
pairs only. A pose collides when any hand geom comes within `clearance` of
an object geom or of the table. The hand is in its open pre-shape unless joint positions are given.
"""

from __future__ import annotations

import mujoco
import numpy as np
import trimesh

from manigrasp.geometry import mat_to_quat, pose_matrix, pregrasp_pose
from manigrasp.hands.base import Hand
from manigrasp.planners.base import Observation
from manigrasp.planners.context import resolve
from manigrasp.sim import SceneConfig, build_scene

DEFAULT_CLEARANCE = 0.001  # [m]


def mesh_object_spec(mesh: trimesh.Trimesh) -> mujoco.MjSpec:
    """An object MJCF spec (body ``object``, free joint) whose one collision geom is `mesh`'s convex hull.

    Used when an observation has no built asset: the hull contains the object,
    so a pose free of it is free of the object (the test is conservative).
    """
    return hull_object_spec(np.asarray(mesh.vertices, float))


def hull_object_spec(vertices: np.ndarray) -> mujoco.MjSpec:
    """An object MJCF spec (body ``object``, free joint) whose one collision geom is the convex hull of
    `vertices` (n, 3) [m] in the object frame."""
    spec = mujoco.MjSpec()
    spec.add_mesh(name="object_hull", uservert=np.asarray(vertices, float).ravel().tolist())
    body = spec.worldbody.add_body(name="object")
    body.add_freejoint(name="object_joint")
    body.add_geom(name="object_hull", type=mujoco.mjtGeom.mjGEOM_MESH, meshname="object_hull", mass=0.1)
    return spec


def _only_hand_vs_rest(model: mujoco.MjModel, hand_geom: np.ndarray, object_geom: np.ndarray, table: int) -> None:
    """Collision bitmasks of the probe's own model: hand-object and hand-table pairs only.

    Object-table and hand-hand pairs are irrelevant to the test and cost most
    of the collision time (the object rests on the table), so they are masked out.
    """
    colliding = (model.geom_contype != 0) | (model.geom_conaffinity != 0)
    hand = hand_geom & colliding
    model.geom_contype[colliding], model.geom_conaffinity[colliding] = 0, 0
    model.geom_contype[hand], model.geom_conaffinity[hand] = 8, 6
    model.geom_contype[object_geom], model.geom_conaffinity[object_geom] = 4, 8
    model.geom_contype[table], model.geom_conaffinity[table] = 2, 8


class HandProbe:
    """One compiled scene for testing many hand poses against the object and the table.

    Args:
        hand: the hand.
        observation: the object's observation (its asset's convex parts are the
            collision geometry; without an asset, the convex hull of its mesh).
        clearance: distance [m] below which hand and object/table count as colliding.
        config: scene parameters (None: the default `SceneConfig`). A planner passes its context's
            (`PlanContext.scene`): the run's pads (compliant or rigid) are the hand's collision geometry.
        hull: (n, 3) points in the world [m] whose convex hull replaces the object's geometry (a point
            cloud's completed hull), or None.
    """

    def __init__(self, hand: Hand, observation: Observation, clearance: float = DEFAULT_CLEARANCE,
                 config: SceneConfig | None = None, hull: np.ndarray | None = None) -> None:
        object_pose = observation.object_pose
        if hull is not None:
            obj, object_pose = hull_object_spec(hull), np.eye(4)
        elif observation.asset is not None:
            obj = observation.asset
        else:
            obj = mesh_object_spec(observation.mesh)
        self.scene = build_scene(hand, obj, config)
        self.hand = hand
        # The scene's table top is z = 0: shift the world so the observed table lands there.
        self.shift = np.eye(4)
        self.shift[2, 3] = -float(observation.table_height)
        self.scene.reset(mount=np.eye(4), object_pose=self.shift @ object_pose)
        model = self.scene.model
        self.root = self.scene.root_body
        self.root_in_tcp = pose_matrix(model.body_pos[self.root], model.body_quat[self.root])
        hand_geom = np.isin(model.geom_bodyid, self.scene.hand_bodies)
        other = np.zeros(model.ngeom, bool)
        other[self.scene.object_geoms] = True
        other[self.scene.table_geom] = True
        self.is_hand, self.is_other = hand_geom, other
        self.is_object = np.zeros(model.ngeom, bool)
        self.is_object[self.scene.object_geoms] = True
        model.geom_margin[hand_geom] = clearance
        _only_hand_vs_rest(model, hand_geom, self.is_object, self.scene.table_geom)
        self.clearance = clearance
        self.rest_qpos = self.scene.data.qpos.copy()

    # ----------------------------------------------------------------- poses
    def roots(self, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Positions (n, 3) and quaternions (n, 4) of the hand's root body for TCP poses (n, 4, 4)."""
        root = self.shift @ np.asarray(poses, float) @ self.root_in_tcp
        return root[:, :3, 3].copy(), mat_to_quat(root[:, :3, :3])

    def place(self, pos: np.ndarray, quat: np.ndarray) -> None:
        """Put the hand's root at `pos` (3,), `quat` (4,) and update kinematics and contacts."""
        model, data = self.scene.model, self.scene.data
        model.body_pos[self.root], model.body_quat[self.root] = pos, quat
        mujoco.mj_kinematics(model, data)
        mujoco.mj_collision(model, data)

    def touching(self) -> bool:
        """Whether any hand geom is within the clearance of the object or table (after `place`)."""
        data = self.scene.data
        if data.ncon == 0:
            return False
        geom = data.contact.geom[:data.ncon]
        hand = self.is_hand[geom]
        other = self.is_other[geom]
        return bool(np.any((hand[:, 0] & other[:, 1]) | (hand[:, 1] & other[:, 0])))

    def collides(self, poses: np.ndarray) -> np.ndarray:
        """(n,) True where the open hand at TCP pose (n, 4, 4) collides with the object or the table."""
        pos, quat = self.roots(poses)
        out = np.zeros(len(pos), bool)
        for i in range(len(pos)):
            self.place(pos[i], quat[i])
            out[i] = self.touching()
        return out

    def free(self, pose: np.ndarray, offset: float | None = None) -> bool:
        """True if the open hand is clear of object and table at `pose` (4, 4) and at its pre-grasp pose
        `offset` [m] back (None: the standard protocol's `pregrasp_offset`)."""
        poses = np.stack([pose, pregrasp_pose(pose, resolve(None, offset).pregrasp_offset)])
        pos, quat = self.roots(poses)
        for i in range(2):
            self.place(pos[i], quat[i])
            if self.touching():
                return False
        return True

    def finger_extents(self) -> tuple[float, float]:
        """How far [m] the fingers' collision geometry extends beyond the TCP along the approach (z), and
        its half-width [m] across the fingers (along x, the pads' width), open hand.

        Measured on the bounding boxes of the finger geoms (a slight
        overestimate for geoms tilted in the TCP frame).
        """
        scene, model, data = self.scene, self.scene.model, self.scene.data
        self.place(*[x[0] for x in self.roots(np.eye(4)[None])])
        tcp = scene.tcp_pose()
        corners = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T
        reach = half_width = 0.0
        for g in np.flatnonzero(self.is_hand & (model.geom_contype != 0)):
            if scene.finger_of_body[model.geom_bodyid[g]] < 0:
                continue
            local = model.geom_aabb[g, :3] + corners * model.geom_aabb[g, 3:]
            world = local @ data.geom_xmat[g].reshape(3, 3).T + data.geom_xpos[g]
            reach = max(reach, float(np.max((world - tcp[:3, 3]) @ tcp[:3, 2])))
            half_width = max(half_width, float(np.max(np.abs((world - tcp[:3, 3]) @ tcp[:3, 0]))))
        self.restore()
        return reach, half_width

    # -------------------------------------------------------- hand joints
    def set_hand_qpos(self, qpos: dict[int, float]) -> None:
        """Set hand joint positions: qpos address -> value (kinematics are updated by the next `place`)."""
        for adr, value in qpos.items():
            self.scene.data.qpos[adr] = value

    def restore(self) -> None:
        """Hand joints back to the open pre-shape, object back to its observed pose."""
        self.scene.data.qpos[:] = self.rest_qpos

    def hand_qpos_addresses(self) -> dict[str, int]:
        """Hand joint name (unprefixed) -> its qpos address (the mount's joints excluded)."""
        model, hand_bodies = self.scene.model, set(self.scene.hand_bodies.tolist())
        out = {}
        for j in range(model.njnt):
            name = model.joint(j).name
            if model.jnt_bodyid[j] in hand_bodies and name.startswith("hand/"):
                out[name.removeprefix("hand/")] = int(model.jnt_qposadr[j])
        return out

    def object_contacts(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Hand-object contacts of the current placement.

        Returns:
            positions (k, 3) [m] in the observation's world, normals (k, 3) pointing
            from the hand into the object, and the hand geom id of each (k,).
        """
        data = self.scene.data
        if data.ncon == 0:
            return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, int)
        con = data.contact
        geom = con.geom[:data.ncon]
        hand_first = self.is_hand[geom[:, 0]] & self.is_object[geom[:, 1]]
        hand_second = self.is_hand[geom[:, 1]] & self.is_object[geom[:, 0]]
        keep = hand_first | hand_second
        normal = con.frame[:data.ncon, :3][keep] * np.where(hand_first[keep], 1.0, -1.0)[:, None]
        pos = con.pos[:data.ncon][keep] - self.shift[:3, 3]
        hand_geom = np.where(hand_first, geom[:, 0], geom[:, 1])[keep]
        return pos, normal, hand_geom

    def table_touched(self) -> np.ndarray:
        """Hand geom ids within the clearance of the table in the current placement."""
        data = self.scene.data
        geom = data.contact.geom[:data.ncon]
        table = self.scene.table_geom
        first = self.is_hand[geom[:, 0]] & (geom[:, 1] == table)
        second = self.is_hand[geom[:, 1]] & (geom[:, 0] == table)
        return np.concatenate([geom[first, 0], geom[second, 1]])
