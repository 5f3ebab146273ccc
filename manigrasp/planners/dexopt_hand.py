"""The kinematic model of a dexterous hand that `dexopt` optimises: points on its links and their Jacobians.

`HandKinematics` compiles the hand alone on a free joint (gravity and dynamics unused) and derives, from the
`Hand` description only (nothing per object, nothing hand-written per hand):

- the hand's *independent* joints: every 1-dof joint that is not the dependent side of a joint-coupling equality
  (``mjEQ_JOINT``: y - y0 = c0 + c1 (x - x0) + c2 (x - x0)^2 + ...; the Inspire and Fourier hands' distal
  joints); dependent joints follow their polynomial, and the chain rule goes through its derivative;
- the map from joints to actuator commands (a joint servo commands its joint, a fixed-tendon servo its tendon's
  length sum_k coef_k q_k) and its Jacobian, and the inverse for a linear map (least squares);
- surface samples on every hand collision geom (fixed in the geom's body, uniform by area, fixed seed; a mesh
  geom's convex hull, the shape MuJoCo collides; plus points along the sharp edges and at the corners);
- pad contact candidates: on every collision body of each finger (`Hand.finger_bodies`) that moves when the
  hand closes, the surface samples farthest along the direction it moves (open -> closed command), the part of
  the link that a squeeze presses on the object (the optimiser uses, per finger, the candidate nearest the
  object, re-chosen as it goes, as DexGraspNet switches contact points); with `wrap`, every moving link of
  every finger is a contact of its own (a wrap, not a fingertip grasp); with `palm`, the palm's front (its
  surface samples farthest along the TCP approach) is one more contact (`pad_finger` numbers the contacts);
- spheres along each finger's collision geoms (for the fingers' mutual penetration), and for each pair on
  different fingers the distance below which they count as penetrating (`sphere_reach`): the sum of their radii,
  or less where the hand's own closing motion brings them closer while MuJoCo finds the fingers' real geoms clear
  of each other (`REST_FRACTIONS` of the open -> closed path). A sphere is as wide as its link, so neighbouring
  fingers' spheres overlap where the links lie side by side (the Fourier's four fingers: 16 mm of summed overlap
  in the open hand, 1000 energy units per metre; the Inspire's 3 mm) although the links never touch: counted, that
  overlap dominated the Fourier's energy (10 of its 10-15) and pushed neighbouring fingers to curl apart.

`evaluate` places a batch of configurations and returns every point in the world with the Jacobians of their
bodies (`mj_jacBody`); `backprop` takes a gradient over points to the reduced coordinates (free-joint tangent
(6) + independent joints): g = sum_b Jp_b^T G_b + Jr_b^T T_b with G_b = sum of the point gradients on body b
and T_b = sum (p - x_b) x dE/dp, i.e. the point Jacobian Jp_b - [p - x_b]x Jr_b applied per body, not per point.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
import trimesh

from manigrasp.errors import PlannerError
from manigrasp.hands.base import Hand

SAMPLE_SPACING = 0.005  # [m] mean spacing of the surface samples on the hand's collision geoms
SHARP_EDGE = 0.5  # [rad] a geom's edges where its faces meet at more than this get samples of their own
PAD_FRACTION = 0.4  # the part of a finger link's surface samples farthest along its closing motion are its pads
PALM_BAND = 0.003  # [m] palm samples within this of its front (along the TCP approach) are its pads
PAD_LINKS = 1  # pads on this many links of each finger, from the tip
REST_FRACTIONS = np.linspace(0.0, 1.0, 21)  # points of the open -> closed path checked for `sphere_reach`
SAMPLE_SEED = 0  # the hand's surface samples are a property of the hand: fixed, not drawn from the planner's rng
_ONE_DOF = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))


@dataclass(frozen=True)
class Points:
    """Points fixed on hand bodies: body ids (n,) and positions in the body frame (n, 3) [m]."""

    bodies: np.ndarray
    local: np.ndarray


class HandKinematics:
    """A dexterous hand on a free joint, as the optimiser sees it (module docstring)."""

    def __init__(self, hand: Hand, spacing: float = SAMPLE_SPACING, palm: bool = False, wrap: bool = False) -> None:
        self.palm, self.wrap = palm, wrap
        self._reduce_fixed: np.ndarray | None = None
        self._chains: tuple[np.ndarray, np.ndarray] | None = None
        if hand.kind != "dexterous":
            raise PlannerError(f"dexopt plans for dexterous hands; {hand.name!r} is a {hand.kind} hand")
        self.hand = hand
        spec = hand.build_spec()
        spec.body(hand.root_body).add_freejoint()
        self.model = spec.compile()
        self.data = mujoco.MjData(self.model)
        m = self.model
        self.root = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, hand.root_body)
        joints = [j for j in range(m.njnt) if int(m.jnt_type[j]) in _ONE_DOF]
        coupled = {}  # dependent joint -> (independent joint, polynomial coefficients)
        for e in range(m.neq):
            if int(m.eq_type[e]) == int(mujoco.mjtEq.mjEQ_JOINT) and m.eq_obj2id[e] >= 0:
                coupled[int(m.eq_obj1id[e])] = (int(m.eq_obj2id[e]), m.eq_data[e, :5].copy())
        self.joints = np.array(joints, int)
        self.joint_names = [m.joint(j).name for j in joints]  # of `joints`, as the hand model names them
        self.independent = np.array([j for j in joints if j not in coupled], int)
        self.coupled = coupled
        self.low = m.jnt_range[self.independent, 0].copy()
        self.high = m.jnt_range[self.independent, 1].copy()
        self.n_q = len(self.independent)
        self._index = {int(j): k for k, j in enumerate(self.independent)}
        self.actuators = np.array([mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, a) for a in hand.actuators])
        if np.any(self.actuators < 0):
            raise PlannerError(f"hand {hand.name!r}: an actuator of {hand.actuators} is not in its model")
        self.ctrl_low = m.actuator_ctrlrange[self.actuators, 0].copy()
        self.ctrl_high = m.actuator_ctrlrange[self.actuators, 1].copy()
        self.kp = m.actuator_gainprm[self.actuators, 0].copy()
        limited = m.actuator_forcelimited[self.actuators].astype(bool)
        self.force_limit = np.where(limited, np.abs(m.actuator_forcerange[self.actuators]).min(axis=1), np.inf)
        self.body_finger = self._body_fingers()
        self._sample_geoms(spacing)
        self.root_in_tcp = self._root_in_tcp()
        self.q_open = self.q_from_ctrl(hand.open_ctrl)
        self.q_closed = self.q_from_ctrl(hand.closed_ctrl)
        self.contacts = self._pads()
        self.spheres, self.sphere_radius = self._spheres()
        self.sphere_finger = self.body_finger[self.spheres.bodies]
        self.sphere_reach = self._sphere_reach()

    # ------------------------------------------------------------------ joints and commands
    def full_qpos(self, root_pos: np.ndarray, root_quat: np.ndarray, q: np.ndarray) -> np.ndarray:
        """(nq,) qpos of the model: free joint (pos, quat) and the joints from the independent ones `q`."""
        m = self.model
        qpos = m.qpos0.copy()
        qpos[:3], qpos[3:7] = root_pos, root_quat
        qpos[m.jnt_qposadr[self.independent]] = q
        for dep, (ind, c) in self.coupled.items():
            x = qpos[m.jnt_qposadr[ind]] - m.qpos0[m.jnt_qposadr[ind]]
            qpos[m.jnt_qposadr[dep]] = m.qpos0[m.jnt_qposadr[dep]] + c[0] + c[1] * x + c[2] * x**2 + c[3] * x**3 \
                + c[4] * x**4
        return qpos

    def reduce_matrix(self, qpos: np.ndarray) -> np.ndarray:
        """(nv, 6 + n_q): d(model dofs)/d(free-joint tangent, independent joints) at `qpos`."""
        m = self.model
        if self._reduce_fixed is None:  # the part that does not depend on qpos: built once
            fixed = np.zeros((m.nv, 6 + self.n_q))
            fixed[:6, :6] = np.eye(6)
            for k, j in enumerate(self.independent):
                fixed[m.jnt_dofadr[j], 6 + k] = 1.0
            self._reduce_fixed = fixed
        out = self._reduce_fixed.copy()
        for dep, (ind, c) in self.coupled.items():
            x = qpos[m.jnt_qposadr[ind]] - m.qpos0[m.jnt_qposadr[ind]]
            slope = c[1] + 2 * c[2] * x + 3 * c[3] * x**2 + 4 * c[4] * x**3
            out[m.jnt_dofadr[dep], 6 + self._index[ind]] = slope
        return out

    def ctrl(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Actuator commands (n_act,) holding the joints at `q` (n_q,), and their Jacobian (n_act, n_q)."""
        m = self.model
        qpos = self.full_qpos(np.zeros(3), np.array([1.0, 0, 0, 0]), q)
        reduce = self.reduce_matrix(qpos)[:, 6:]  # (nv, n_q)
        out, jac = np.zeros(len(self.actuators)), np.zeros((len(self.actuators), self.n_q))
        for a, act in enumerate(self.actuators):
            kind, target = int(m.actuator_trntype[act]), int(m.actuator_trnid[act, 0])
            if kind == int(mujoco.mjtTrn.mjTRN_JOINT):
                rows = [(m.jnt_qposadr[target], m.jnt_dofadr[target], 1.0)]
            elif kind == int(mujoco.mjtTrn.mjTRN_TENDON) and all(
                    int(m.wrap_type[w]) == int(mujoco.mjtWrap.mjWRAP_JOINT)
                    for w in range(m.tendon_adr[target], m.tendon_adr[target] + m.tendon_num[target])):
                rows = [(m.jnt_qposadr[m.wrap_objid[w]], m.jnt_dofadr[m.wrap_objid[w]], float(m.wrap_prm[w]))
                        for w in range(m.tendon_adr[target], m.tendon_adr[target] + m.tendon_num[target])]
            else:
                raise PlannerError(f"hand {self.hand.name!r}: actuator {m.actuator(act).name!r} drives neither a "
                                   "joint nor a fixed tendon; dexopt cannot map joints to its command")
            for adr, dof, coef in rows:
                out[a] += coef * qpos[adr]
                jac[a] += coef * reduce[dof]
        return out, jac

    def q_from_ctrl(self, ctrl: np.ndarray) -> np.ndarray:
        """Independent joints (n_q,) whose commands are closest to `ctrl` (least squares), within joint ranges."""
        q = np.clip(np.zeros(self.n_q), self.low, self.high)
        for _ in range(3):  # Gauss-Newton: exact in one step for linear couplings
            c, jac = self.ctrl(q)
            q = np.clip(q + np.linalg.lstsq(jac, np.asarray(ctrl, float) - c, rcond=None)[0], self.low, self.high)
        return q

    # ------------------------------------------------------------------ points in the world
    def evaluate(self, root_pos: np.ndarray, root_quat: np.ndarray, q: np.ndarray, jacobians: bool = True
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Place R configurations: root positions (R, 3), quaternions (R, 4), independent joints (R, n_q).

        Returns body positions (R, nb, 3) and rotations (R, nb, 3, 3) of `self.bodies`, their reduced
        translational and rotational Jacobians (R, nb, 3, 6 + n_q) each (zeros unless `jacobians`), and the
        qpos (R, nq). The Jacobians are MuJoCo's `mj_jacBody` for all bodies at once: from the dofs' motion
        axes `cdof` (after `mj_comPos`), each dof that moves a body contributing its angular axis and, at the
        body's origin, its linear part plus the axis crossed with the origin's offset from the tree's centre of
        mass (`mj_jac`'s own sums, bit for bit; a few NumPy expressions per restart instead of a call and two
        matrix products per body).
        """
        m, d = self.model, self.data
        r, nb = len(root_pos), len(self.bodies)
        xpos, xmat = np.zeros((r, nb, 3)), np.zeros((r, nb, 3, 3))
        jp, jr = np.zeros((r, nb, 3, 6 + self.n_q)), np.zeros((r, nb, 3, 6 + self.n_q))
        qpos_all = np.zeros((r, m.nq))
        moves, tree = self._dof_chains()
        for i in range(r):
            qpos = self.full_qpos(root_pos[i], root_quat[i], q[i])
            qpos_all[i] = qpos
            d.qpos[:] = qpos
            mujoco.mj_kinematics(m, d)
            xpos[i], xmat[i] = d.xpos[self.bodies], d.xmat[self.bodies].reshape(nb, 3, 3)
            if not jacobians:
                continue
            mujoco.mj_comPos(m, d)
            reduce = self.reduce_matrix(qpos)
            axis, linear = d.cdof[:, :3], d.cdof[:, 3:]  # (nv, 3) each
            offset = xpos[i] - d.subtree_com[tree]  # (nb, 3)
            jacr = moves[..., None] * axis  # (nb, nv, 3)
            jacp = moves[..., None] * (linear + _cross(axis, offset[:, None, :]))
            jp[i], jr[i] = jacp.transpose(0, 2, 1) @ reduce, jacr.transpose(0, 2, 1) @ reduce
        return xpos, xmat, jp, jr, qpos_all

    def _dof_chains(self) -> tuple[np.ndarray, np.ndarray]:
        """(nb, nv) whether each dof moves each of `self.bodies` (the dofs of the body, or of its nearest ancestor
        with dofs, and their ancestors: `mj_jac`'s chain), and (nb,) the root body of each one's tree."""
        if self._chains is None:
            m = self.model
            moves = np.zeros((len(self.bodies), m.nv))
            for k, b in enumerate(self.bodies):
                body = int(b)
                while body and not m.body_dofnum[body]:
                    body = int(m.body_parentid[body])
                dof = int(m.body_dofadr[body] + m.body_dofnum[body] - 1) if body else -1
                while dof >= 0:
                    moves[k, dof] = 1.0
                    dof = int(m.dof_parentid[dof])
            self._chains = (moves, m.body_rootid[self.bodies].copy())
        return self._chains

    def world(self, points: Points, xpos: np.ndarray, xmat: np.ndarray) -> np.ndarray:
        """(R, n, 3) world positions of `points` for placed bodies (from `evaluate`)."""
        slot = self._slot[points.bodies]
        out = np.empty((xpos.shape[0], len(slot), 3))
        for k in np.unique(slot):  # per body: one batched matrix product over the restarts (no (R, n, 3, 3) gather)
            idx = np.flatnonzero(slot == k)
            out[:, idx] = xpos[:, k, None] + points.local[idx] @ xmat[:, k].transpose(0, 2, 1)
        return out

    def world_near(self, points: Points, xpos: np.ndarray, xmat: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                   below: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The world positions of those of `points` that may lie in the box [`lo`, `hi`] (3,) [m] or below the
        height `below` [m], for placed bodies (R of them, from `evaluate`): restart indices (N,), point indices
        (N,) and positions (N, 3). A body is skipped in a restart when the sphere about its origin holding all
        its points misses both regions (conservative: every point in a region is returned, with others)."""
        slot = self._slot[points.bodies]
        reach = np.zeros(len(self.bodies))
        np.maximum.at(reach, slot, np.linalg.norm(points.local, axis=1))
        gap = np.maximum(np.maximum(lo - xpos, xpos - hi), 0.0)  # (R, nb, 3) body origin to the box
        near = (np.linalg.norm(gap, axis=2) <= reach) | (xpos[..., 2] - reach < below)  # (R, nb)
        rows, cols, out = [], [], []
        for k in np.flatnonzero(near.any(axis=0)):
            idx = np.flatnonzero(slot == k)
            if len(idx) == 0:
                continue
            r = np.flatnonzero(near[:, k])
            rows.append(np.repeat(r, len(idx)))
            cols.append(np.tile(idx, len(r)))
            out.append((xpos[r, k, None] + points.local[idx] @ xmat[r, k].transpose(0, 2, 1)).reshape(-1, 3))
        if not out:
            return np.zeros(0, int), np.zeros(0, int), np.zeros((0, 3))
        return np.concatenate(rows), np.concatenate(cols), np.concatenate(out)

    def backprop(self, points: Points, world: np.ndarray, grad: np.ndarray, xpos: np.ndarray, jp: np.ndarray,
                 jr: np.ndarray) -> np.ndarray:
        """(R, 6 + n_q) gradient over the reduced coordinates of a function with gradient `grad` (R, n, 3) at
        the points' world positions `world` (R, n, 3) (module docstring)."""
        slot = self._slot[points.bodies]
        r, nb = len(world), len(self.bodies)
        onehot = np.zeros((nb, len(slot)))
        onehot[slot, np.arange(len(slot))] = 1.0
        torque = np.cross(world - xpos[:, slot], grad)
        both = onehot @ np.concatenate([grad, torque], axis=2).transpose(1, 0, 2).reshape(len(slot), -1)
        both = both.reshape(nb, r, 6).transpose(1, 0, 2)  # (R, nb, 6): sums of gradients and of torques
        return np.einsum("rbi,rbij->rj", both[..., :3], jp) + np.einsum("rbi,rbij->rj", both[..., 3:], jr)

    # ------------------------------------------------------------------ derived geometry
    def _body_fingers(self) -> np.ndarray:
        """(nbody,) finger index of each body (-1: palm/root)."""
        m = self.model
        out = np.full(m.nbody, -1, int)
        ids = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, b) for b in self.hand.finger_bodies]
        for b in range(m.nbody):
            a = b
            while a > 0:
                if a in ids:
                    out[b] = ids.index(a)
                    break
                a = int(m.body_parentid[a])
        return out

    def _geom_mesh(self, g: int) -> trimesh.Trimesh | None:
        """The collision geom `g` as a mesh in its own frame, or None for a type we do not sample (planes)."""
        m = self.model
        size, kind = m.geom_size[g], int(m.geom_type[g])
        t = mujoco.mjtGeom
        if kind == int(t.mjGEOM_SPHERE):
            return trimesh.creation.icosphere(subdivisions=2, radius=size[0])
        if kind == int(t.mjGEOM_CAPSULE):
            return trimesh.creation.capsule(height=2 * size[1], radius=size[0])
        if kind == int(t.mjGEOM_CYLINDER):
            return trimesh.creation.cylinder(radius=size[0], height=2 * size[1])
        if kind == int(t.mjGEOM_BOX):
            return trimesh.creation.box(extents=2 * size[:3])
        if kind == int(t.mjGEOM_ELLIPSOID):
            sphere = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
            sphere.vertices *= size[:3]
            return sphere
        if kind == int(t.mjGEOM_MESH):
            mesh = int(m.geom_dataid[g])
            v0, nv = m.mesh_vertadr[mesh], m.mesh_vertnum[mesh]
            f0, nf = m.mesh_faceadr[mesh], m.mesh_facenum[mesh]
            return trimesh.Trimesh(m.mesh_vert[v0:v0 + nv].copy(), m.mesh_face[f0:f0 + nf].copy(), process=False)
        return None

    def _sample_geoms(self, spacing: float) -> None:
        m = self.model
        hand_bodies = [b for b in range(m.nbody) if b > 0]
        rng, rng_hull = np.random.default_rng(SAMPLE_SEED), np.random.default_rng(SAMPLE_SEED + 1)
        bodies, local, geoms, shape, shape_geoms = [], [], [], [], []
        for g in range(m.ngeom):
            if m.geom_bodyid[g] not in hand_bodies or (m.geom_contype[g] == 0 and m.geom_conaffinity[g] == 0):
                continue
            mesh = self._geom_mesh(g)
            if mesh is None:
                continue
            rot = np.zeros(9)
            mujoco.mju_quat2Mat(rot, m.geom_quat[g])
            rot = rot.reshape(3, 3)
            count = max(8, int(np.ceil(mesh.area / spacing**2)))
            pts = np.asarray(trimesh.sample.sample_surface(mesh, count, seed=rng)[0])
            shape.append(pts @ rot.T + m.geom_pos[g])  # the geom's own surface: its finger spheres
            shape_geoms.append(np.full(len(pts), g))
            if int(m.geom_type[g]) == int(mujoco.mjtGeom.mjGEOM_MESH):
                # MuJoCo collides a mesh geom as its convex hull: sample the hull, not the (often concave) mesh.
                mesh = mesh.convex_hull
                count = max(8, int(np.ceil(mesh.area / spacing**2)))
                pts = np.asarray(trimesh.sample.sample_surface(mesh, count, seed=rng_hull)[0])
            pts = np.concatenate([pts, _edge_points(mesh, spacing)]) @ rot.T + m.geom_pos[g]
            bodies.append(np.full(len(pts), int(m.geom_bodyid[g])))
            local.append(pts)
            geoms.append(np.full(len(pts), g))
        if not bodies:
            raise PlannerError(f"hand {self.hand.name!r} has no collision geometry to optimise")
        self.samples = Points(np.concatenate(bodies), np.concatenate(local))
        self.sample_geom = np.concatenate(geoms)
        self._shape_local, self._shape_geom = np.concatenate(shape), np.concatenate(shape_geoms)
        # Pads and spheres lie on these bodies too: they are the bodies whose Jacobians `evaluate` computes.
        self.bodies = np.unique(self.samples.bodies)
        self._slot = np.full(m.nbody, -1, int)
        self._slot[self.bodies] = np.arange(len(self.bodies))

    def _root_in_tcp(self) -> np.ndarray:
        """(4, 4) pose of the root body in the TCP frame."""
        m, d = self.model, self.data
        d.qpos[:] = m.qpos0
        d.qpos[:7] = [0, 0, 0, 1, 0, 0, 0]
        mujoco.mj_kinematics(m, d)
        site = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, self.hand.tcp_site)
        tcp = np.eye(4)
        tcp[:3, :3], tcp[:3, 3] = d.site_xmat[site].reshape(3, 3), d.site_xpos[site]
        return np.linalg.inv(tcp)

    def _pads(self) -> Points:
        """Pad candidates on every finger link with collision geometry (module docstring); `pad_finger` (n,)
        says whose finger each is."""
        ident = np.array([1.0, 0, 0, 0])
        q_mid = self.q_open + 0.1 * (self.q_closed - self.q_open)
        xpos0, xmat0, *_ = self.evaluate(np.zeros((1, 3)), ident[None], self.q_open[None], jacobians=False)
        xpos1, xmat1, *_ = self.evaluate(np.zeros((1, 3)), ident[None], q_mid[None], jacobians=False)
        bodies, local, finger, geoms = [], [], [], []
        for f in range(len(self.hand.finger_bodies)):
            links = [b for b in np.unique(self.samples.bodies) if self.body_finger[b] == f]
            if not links:
                raise PlannerError(f"hand {self.hand.name!r}: finger {self.hand.finger_bodies[f]!r} has no "
                                   "collision geometry")
            chosen_links = sorted(links, key=self._depth, reverse=True)  # the tip first
            for link in chosen_links if self.wrap else chosen_links[:PAD_LINKS]:
                on_link = self.samples.bodies == link
                pts = self.samples.local[on_link]
                k = self._slot_of(link)
                before = xpos0[0, k] + pts @ xmat0[0, k].T
                motion = (xpos1[0, k] + pts @ xmat1[0, k].T - before).mean(axis=0)
                if np.linalg.norm(motion) < 1e-6:  # a link that does not move when the hand closes: no pad
                    continue
                along = before @ motion / np.linalg.norm(motion)
                in_front = along >= np.quantile(along, 1.0 - PAD_FRACTION)
                front = pts[in_front]
                bodies.extend([link] * len(front))
                local.extend(front)
                geoms.extend(self.sample_geom[on_link][in_front])
                finger.extend([len(set(finger)) if self.wrap else f] * len(front))
            if not finger or (not self.wrap and finger[-1] != f):
                raise PlannerError(f"hand {self.hand.name!r}: finger {self.hand.finger_bodies[f]!r} does not move "
                                   "when the hand closes; no pad direction")
        if self.palm:  # the palm as one more contact: its samples farthest along the TCP approach (z)
            on_palm = np.flatnonzero(self.body_finger[self.samples.bodies] < 0)
            tcp_in_root = np.linalg.inv(self.root_in_tcp)
            rel = xpos0[0, self._slot[self.samples.bodies[on_palm]]] + np.einsum(
                "nij,nj->ni", xmat0[0, self._slot[self.samples.bodies[on_palm]]], self.samples.local[on_palm])
            along = (rel - tcp_in_root[:3, 3]) @ tcp_in_root[:3, 2]
            front = on_palm[along >= along.max() - PALM_BAND]
            bodies.extend(self.samples.bodies[front])
            local.extend(self.samples.local[front])
            geoms.extend(self.sample_geom[front])
            finger.extend([len(set(finger))] * len(front))
        self.pad_finger = np.array(finger, int)
        self.pad_geom = np.array(geoms, int)
        return Points(np.array(bodies, int), np.array(local))

    def _slot_of(self, body: int) -> int:
        return int(self._slot[body])

    def _depth(self, body: int) -> int:
        depth, b = 0, body
        while b > 0:
            b = int(self.model.body_parentid[b])
            depth += 1
        return depth

    def body_id(self, name: str) -> int:
        """The id of the hand body `name` in this model, -1 if there is none."""
        return int(mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, name))

    def finger_overlap(self, qpos: np.ndarray) -> float:
        """Deepest penetration [m] (>= 0) between the real collision geoms of different fingers at `qpos` (MuJoCo's
        collision, the model's own contact filters)."""
        m, d = self.model, self.data
        d.qpos[:] = qpos
        mujoco.mj_kinematics(m, d)
        mujoco.mj_collision(m, d)
        depth = 0.0
        for c in range(d.ncon):
            f1, f2 = self.body_finger[m.geom_bodyid[d.contact.geom[c]]]
            if f1 != f2 and f1 >= 0 and f2 >= 0:
                depth = max(depth, -float(d.contact.dist[c]))
        return depth

    def _sphere_reach(self) -> np.ndarray:
        """(s, s) distances [m] below which two spheres of different fingers penetrate (module docstring): r_i + r_j,
        lowered to the least distance the pair has at the configurations of the open -> closed path where the
        fingers' real geoms are clear of each other (`finger_overlap` 0); 0 for spheres of one finger."""
        reach = self.sphere_radius[:, None] + self.sphere_radius[None]
        origin, unit = np.zeros((1, 3)), np.array([[1.0, 0.0, 0.0, 0.0]])
        for t in REST_FRACTIONS:
            q = self.q_open + t * (self.q_closed - self.q_open)
            if self.finger_overlap(self.full_qpos(origin[0], unit[0], q)) > 0.0:
                continue
            xpos, xmat, *_ = self.evaluate(origin, unit, q[None], jacobians=False)
            c = self.world(self.spheres, xpos, xmat)[0]
            reach = np.minimum(reach, np.linalg.norm(c[:, None] - c[None], axis=2))
        return np.where(self.sphere_finger[:, None] != self.sphere_finger[None], reach, 0.0)

    def _spheres(self) -> tuple[Points, np.ndarray]:
        """Spheres along each finger collision geom (its own surface's samples, not its hull's): centres on its longest
        axis, radius its second half-extent."""
        m = self.model
        bodies, local, radius = [], [], []
        for g in np.unique(self._shape_geom):
            b = int(m.geom_bodyid[g])
            if self.body_finger[b] < 0:
                continue
            pts = self._shape_local[self._shape_geom == g]
            centre = pts.mean(axis=0)
            _, sv, vt = np.linalg.svd(pts - centre, full_matrices=False)
            coords = (pts - centre) @ vt.T
            half = np.maximum(np.abs(coords).max(axis=0), 1e-4)
            r = float(0.9 * half[1])
            n = max(1, int(np.ceil(half[0] / r)))
            span = max(half[0] - r, 0.0)
            for t in np.linspace(-span, span, n):
                bodies.append(b)
                local.append(centre + t * vt[0])
                radius.append(r)
        return Points(np.array(bodies, int), np.array(local).reshape(-1, 3)), np.array(radius)


def _edge_points(mesh: trimesh.Trimesh, spacing: float) -> np.ndarray:
    """(n, 3) points along the sharp edges of `mesh` (faces meeting at more than `SHARP_EDGE` [rad]), at most
    `spacing` [m] apart and including both ends (the corners): an edge or corner between area samples would
    otherwise press into the object unseen (a box's edge between two faces' samples)."""
    sharp = mesh.face_adjacency_edges[mesh.face_adjacency_angles > SHARP_EDGE]
    out = [np.zeros((0, 3))]
    for a, b in mesh.vertices[sharp]:
        n = max(1, int(np.ceil(np.linalg.norm(b - a) / spacing)))
        out.append(a + np.linspace(0.0, 1.0, n + 1)[:, None] * (b - a))
    return np.unique(np.round(np.concatenate(out), 9), axis=0)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b over the last axis (length 3), broadcast: `np.cross`'s products and differences, without its
    per-call axis handling (a tenth of a planning call's CPU when `evaluate` called `np.cross`)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)
