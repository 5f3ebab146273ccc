"""The five-finger hands that ship with robosuite (GR1's Inspire and Fourier hands), 6 actuators each.

robosuite gives every joint its own servo (12 on the Inspire, 11 on the
Fourier) and copies one of 6 commands onto them in Python. Here each finger
is one tendon-driven degree of freedom, as in the real hands (one motor per
finger, one for the thumb's bend, one for its rotation):

- a fixed tendon per finger, length L = sum(c_i q_i) with c_i proportional to
  each joint's range, and the finger's joints coupled in that proportion
  (q_i = c_i q_lead, a stiff joint equality: the real hands' fingers are
  one-motor linkages), so they flex together and reach their limits together.
  Adaptive fingers (uncoupled, `FiveFingerModel.coupled` False) cannot hold
  a grasp stiffly (a tendon of fixed length leaves the finger free to move):
  a can grasped by hand crept 12 mm (Inspire) and 36 mm (Fourier, dropped) in
  the hand under the standard protocol's lift and perturbations, and slipped
  out in the lift with the stiffened hold; coupled, 20 and 12 mm without the
  hold and 1-1.5 mm with it (`manigrasp.control.FingerHold`);
- one force-limited position servo per tendon, plus one for thumb rotation;
  the bending servos are soft (`KP`), so a blocked finger's force grows
  gradually with the command and the grip force can be regulated through the
  synergy (`manigrasp.control.GripController`); the thumb's rotation, held at
  its opposed stop, is stiff (`ROTATION_KP`) so the fingers' squeeze cannot
  push the thumb out of opposition;
- the thumb's rotation joint is re-referenced so that the model's default
  configuration (qpos0) is the open pre-shape: thumb rotated into opposition,
  everything else straight. The synergy s then flexes fingers and thumb
  together (closed = every tendon commanded past its closed stop, so a finger
  blocked by an object pushes at its force limit).

Frames (the stand-alone model's world frame, right hand; the left mirrors y):
the palm faces -x, fingers point -z, the opposed thumb sticks out along -x
above the fingers. TCP: z (approach) = -x, the palm normal; y (closing, from
finger 1 = thumb toward the other fingers) = -z; x = y cross z runs across
the palm, the axis of a can held in a power grasp. The TCP sits at the centre
of the open hand's cavity, the box bounded by the palm, the tip of the opposed
thumb, the thumb's underside and the fingertips; `max_width` is the smaller
side of that box (the widest cylinder the open hand encloses).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from manigrasp.errors import HandError
from manigrasp.hands.base import Hand
from manigrasp.hands.from_robosuite import build
from manigrasp.hands.from_robosuite.source import load_gripper_spec

FINGERS = ("index", "middle", "ring", "pinky")
# Servo stiffness of every tendon [N m/rad]; tendon force limits are per model. Soft on purpose: a finger
# blocked at tendon length L pushes with kp (u - L) up to its limit, so from contact the force grows over a
# wide part of the synergy (0.6 N m / 0.5 = 1.2 rad of command, a third of a finger's travel) instead of
# jumping to the limit within 3% of it (kp = 5), and the grip force can be regulated through the synergy.
KP = 0.5
# Servo stiffness of the thumb's rotation [N m/rad]. The rotation is always commanded to its opposed stop and takes
# no part in regulating the grip, so it needs no softness: at KP the four curling fingers pushed the thumb off its
# stop (1.30 -> 1.10 rad against 0.12 N m) and rolled the object toward it, 15-20 mm/s, the main cause of
# `slipped_lift` for power grasps (reduced dexterous benchmark: 10/40 successes at KP, 22/40 at 50, 21/40 at 200).
ROTATION_KP = 50.0
# Rotor inertia reflected through each finger joint's drive [kg m^2] (MuJoCo armature). robosuite's links weigh
# 0.1 kg with inertias of ~1e-5 kg m^2 and no armature; MuJoCo's joint limits (and contacts) are soft in proportion
# to the inverse inertia they act on, so a 0.6-0.9 N m tendon pushed those joints up to 1.2 rad past their stops
# (the thumb folding through itself on a full close). 1e-2 keeps every stop within 0.005 rad under the tendon
# forces; free closing speed is unchanged (it is set by the joints' damping, 1 N m s/rad: 0.6 rad/s per N m).
ARMATURE = 1e-2
# What the real hands' fingertips are covered with (shown in the hand's notes; docs/protocol.md "Dexterous fingertips").
# With `pads: compliant` the distal links' collision geoms (`fingertip_geoms`) touch with the pad rubber's
# friction, `SceneConfig.pad_friction`.
FINGERTIP_COVER = {
    "inspire": ("fingertips: the Inspire RH56's tactile version (RH56DFTP) carries tactile skins on the fingers and "
                "the palm (Inspire Robots user manual PRJ-02-TS-U-010, as cited by the inspire_rh56dftp driver); the "
                "skins' material was not found in a source; with pads: compliant the distal links touch with the "
                "pad rubber's friction (pad_friction), an elastomer skin assumed"),
    "fourier": ("fingertips: no source found for the covering of the Fourier GR-1 hand's fingertips; with pads: "
                "compliant the distal links touch with the pad rubber's friction (pad_friction) like the other "
                "dexterous hands, an assumption, not a sourced value"),
}


@dataclass(frozen=True)
class FiveFingerModel:
    """Names and limits of one robosuite five-finger hand (`{f}` = index, middle, ring, pinky)."""

    name: str
    xml: str
    root_body: str
    palm_body: str
    thumb_rotation: str  # joint
    thumb_bend: tuple[str, ...]  # joints, proximal first
    finger_joints: tuple[str, str]  # patterns with {f}: proximal, distal
    thumb_body: str  # first bending thumb link: its subtree is "the thumb"
    thumb_tip: str  # body
    finger_body: str  # pattern with {f}: proximal link, its subtree is "the finger"
    finger_tip: str  # pattern with {f}
    finger_torque: float  # tendon force limit of a finger [N m]
    thumb_torque: float  # tendon force limit of the thumb bend and rotation [N m]
    kp: float = KP  # servo stiffness of every bending tendon [N m/rad]
    rotation_kp: float = ROTATION_KP  # servo stiffness of the thumb's rotation [N m/rad]
    armature: float = ARMATURE  # reflected drive inertia of every hinge joint [kg m^2]
    link_mass: float | None = None  # if set, the mass of every collision geom [kg]
    coupled: bool = True  # each finger's joints move in proportion (a linkage), not adaptively
    thumb_frame: tuple[tuple[float, ...], tuple[float, ...]] | None = None  # if set, (pos, quat) of thumb_body

    def finger_tendon(self, finger: str) -> tuple[str, ...]:
        return tuple(pattern.format(f=finger) for pattern in self.finger_joints)


# robosuite's inspire_left_hand.xml (with the same numbers as the Inspire URDF of Unitree's H1) does not mirror the
# right hand's thumb: its pitch joint's frame is rpy (-1.5708, 0, 0.16939) at (0.0099867, 0.0098242, -0.0089) where
# the right's (1.5708, 0, 2.8587) at (-0.0088099, 0.010892, -0.00925) mirrors to rpy (-1.5708, 0, 0.28289): the
# left thumb flexes in a plane tilted 6.5 deg away, its tip 6-10 mm further toward the index finger along the palm
# (every other body frame mirrors the right's within 0.2 mm). The left hand gets the mirror of the right's frame,
# so the pair are mirror images (a hand-placed can crept 2.4 mm in the left hand, 1.5 mm in the right).
INSPIRE_LEFT_THUMB = ((0.0088099, 0.010892, -0.00925), (0.7, -0.7, -0.1, 0.1))


def _inspire(side: str) -> FiveFingerModel:
    s = side[0]
    return FiveFingerModel(
        name=f"inspire_{side}", xml=f"inspire_{side}_hand.xml", root_body=f"{side}_hand", palm_body=f"{s}_palm",
        thumb_rotation=f"joint_{s}_thumb_proximal_1",
        thumb_bend=(f"joint_{s}_thumb_proximal_2", f"joint_{s}_thumb_middle", f"joint_{s}_thumb_distal"),
        finger_joints=(f"joint_{s}_{{f}}_proximal", f"joint_{s}_{{f}}_distal"),
        thumb_body=f"{s}_thumb_proximal_2", thumb_tip=f"{s}_thumb_distal",
        finger_body=f"{s}_{{f}}_proximal", finger_tip=f"{s}_{{f}}_distal",
        finger_torque=0.6, thumb_torque=0.9, thumb_frame=INSPIRE_LEFT_THUMB if side == "left" else None)


def _fourier(side: str) -> FiveFingerModel:
    s = side[0].upper()
    return FiveFingerModel(
        name=f"fourier_{side}", xml=f"fourier_{side}_hand.xml", root_body=f"{side}_hand", palm_body=f"{side[0]}_palm",
        thumb_rotation=f"{s}_thumb_proximal_yaw_joint",
        thumb_bend=(f"{s}_thumb_proximal_pitch_joint", f"{s}_thumb_distal_joint"),
        finger_joints=(f"{s}_{{f}}_proximal_joint", f"{s}_{{f}}_intermediate_joint"),
        thumb_body=f"{s}_thumb_proximal_link", thumb_tip=f"{s}_thumb_distal_link",
        finger_body=f"{s}_{{f}}_proximal_link", finger_tip=f"{s}_{{f}}_intermediate_link",
        finger_torque=0.6, thumb_torque=0.9,
        # robosuite's fourier_right_hand.xml gives every link 0.5 kg (a 6 kg hand) where its mirror
        # fourier_left_hand.xml gives 0.1 kg; the right hand gets the left hand's masses.
        link_mass=0.1 if side == "right" else None)


MODELS = {m.name: m for side in ("right", "left") for m in (_inspire(side), _fourier(side))}


def _range(spec: mujoco.MjSpec, joint: str) -> float:
    low, high = spec.joint(joint).range
    return float(high - low)


def tendons(spec: mujoco.MjSpec, model: FiveFingerModel) -> dict[str, dict[str, float]]:
    """Actuated tendons: name -> {joint: coefficient}; coefficients are joint range / lead joint range."""
    chains = {"thumb_bend": model.thumb_bend} | {f: model.finger_tendon(f) for f in FINGERS}
    out = {"thumb_rotation": {model.thumb_rotation: 1.0}}
    for name, joints in chains.items():
        lead = _range(spec, joints[0])
        out[name] = {joint: _range(spec, joint) / lead for joint in joints}
    return out


def _force_limit(model: FiveFingerModel, tendon: str) -> float:
    return model.thumb_torque if tendon.startswith("thumb") else model.finger_torque


def _closed_length(spec: mujoco.MjSpec, joints: dict[str, float]) -> float:
    return sum(coef * float(spec.joint(joint).range[1]) for joint, coef in joints.items())


def _base_spec(model: FiveFingerModel) -> mujoco.MjSpec:
    """The robosuite model with 6 tendon servos and the thumb opposed at qpos0; no TCP yet."""
    spec, _ = load_gripper_spec(model.xml)
    build.delete_all(spec, spec.actuators)
    if model.link_mass is not None:
        for geom in spec.geoms:
            if geom.contype or geom.conaffinity:
                geom.mass = model.link_mass
    if model.thumb_frame is not None:
        spec.body(model.thumb_body).pos, spec.body(model.thumb_body).quat = model.thumb_frame
    for joint in spec.joints:
        if joint.type == mujoco.mjtJoint.mjJNT_HINGE:
            joint.armature = model.armature
    opposed = float(spec.joint(model.thumb_rotation).range[1])
    build.set_joint_default(spec, model.thumb_rotation, opposed)
    for name, joints in tendons(spec, model).items():
        if model.coupled:
            lead, *followers = joints
            for joint in followers:
                build.couple_joints(spec, joint, lead, joints[joint])
        force = _force_limit(model, name)
        closed = _closed_length(spec, joints)
        high = closed if name == "thumb_rotation" else closed + force / model.kp
        kp = model.rotation_kp if name == "thumb_rotation" else model.kp
        build.add_tendon_position_actuator(spec, name, joints, kp=kp, force_limit=force, ctrlrange=(0.0, high))
    return spec


def _spec(model: FiveFingerModel, tcp_pos: tuple[float, float, float]) -> mujoco.MjSpec:
    spec = _base_spec(model)
    build.add_tcp_site(spec, model.root_body, tcp_pos, build.quat_from_axes((0, 0, -1), (-1, 0, 0)))
    return spec


def _vertices(mj: mujoco.MjModel, data: mujoco.MjData, bodies: set[int]) -> np.ndarray:
    """World vertices (n, 3) [m] of the collision meshes of `bodies`."""
    chunks = []
    for geom in range(mj.ngeom):
        if mj.geom_bodyid[geom] not in bodies or not (mj.geom_contype[geom] or mj.geom_conaffinity[geom]):
            continue
        mesh = mj.geom_dataid[geom]
        verts = mj.mesh_vert[mj.mesh_vertadr[mesh]:mj.mesh_vertadr[mesh] + mj.mesh_vertnum[mesh]]
        chunks.append(data.geom_xpos[geom] + verts @ data.geom_xmat[geom].reshape(3, 3).T)
    return np.concatenate(chunks)


def cavity(mj: mujoco.MjModel, data: mujoco.MjData, model: FiveFingerModel) -> tuple[np.ndarray, float, float]:
    """Centre [m] of the open hand's cavity, its depth along -x and its span along -z [m] (at `data`'s pose)."""
    palm = _vertices(mj, data, {mj.body(model.palm_body).id})
    thumb = _vertices(mj, data, build.subtree_bodies(mj, model.thumb_body))
    tip = _vertices(mj, data, {mj.body(model.thumb_tip).id})
    finger_tips = [_vertices(mj, data, {mj.body(model.finger_tip.format(f=f)).id}) for f in FINGERS]
    palm_front, thumb_reach = float(np.max(-palm[:, 0])), float(np.max(-tip[:, 0]))
    thumb_under = float(np.max(-thumb[:, 2]))
    finger_reach = min(float(np.max(-v[:, 2])) for v in finger_tips)
    across = float(np.mean([v[:, 1].mean() for v in finger_tips]))
    centre = np.array([-(palm_front + thumb_reach) / 2, across, -(thumb_under + finger_reach) / 2])
    return centre, thumb_reach - palm_front, finger_reach - thumb_under


def tip_forces(mj: mujoco.MjModel, data: mujoco.MjData, model: FiveFingerModel,
               spec: mujoco.MjSpec) -> dict[str, float]:
    """Fingertip force [N] of each bending tendon at its force limit, at `data`'s pose.

    Statics of the blocked finger: the tendon force f puts torques tau = f c on
    the finger's joints (c: tendon coefficients), balanced by a force F at the
    centre of the distal link's collision mesh (the mid-pad contact) through tau = J^T F, so F = pinv(J^T) f c
    with J the tip's translational Jacobian over the finger's joints.
    """
    forces = {}
    jacp = np.zeros((3, mj.nv))
    for name, joints in tendons(spec, model).items():
        if name == "thumb_rotation":
            continue
        tip = model.thumb_tip if name == "thumb_bend" else model.finger_tip.format(f=name)
        body = mj.body(tip).id
        point = _vertices(mj, data, {body}).mean(axis=0)
        mujoco.mj_jac(mj, data, jacp, None, point, body)
        coefs = np.zeros(mj.nv)
        for joint, coef in joints.items():
            coefs[mj.jnt_dofadr[mj.joint(joint).id]] = coef
        forces[name] = _force_limit(model, name) * float(coefs @ coefs) / float(np.linalg.norm(jacp @ coefs))
    return forces


def fingertip_geoms(spec: mujoco.MjSpec, model: FiveFingerModel) -> tuple[str, ...]:
    """Colliding geoms of the five distal links (thumb first): the fingertips that `FINGERTIP_COVER` describes."""
    tips = (model.thumb_tip, *(model.finger_tip.format(f=f) for f in FINGERS))
    names = tuple(geom.name for tip in tips for geom in spec.body(tip).geoms if geom.contype or geom.conaffinity)
    if len(names) != len(tips) or not all(names):
        raise HandError(f"{model.name}: expected one named collision geom per distal link, got {names}")
    return names


def make(name: str) -> Hand:
    """The robosuite five-finger hand `name` (inspire_right, inspire_left, fourier_right, fourier_left)."""
    return make_from(MODELS[name])


def make_from(model: FiveFingerModel) -> Hand:
    """The `Hand` of a five-finger model description (e.g. one of `MODELS` with other force limits)."""
    name = model.name
    base = _base_spec(model)
    mj = base.compile()
    data = mujoco.MjData(mj)
    mujoco.mj_kinematics(mj, data)
    mujoco.mj_comPos(mj, data)
    centre, depth, span = cavity(mj, data, model)
    forces = tip_forces(mj, data, model, base)
    grip = min(forces["thumb_bend"], sum(forces[f] for f in FINGERS))
    tcp = tuple(float(v) for v in np.round(centre, 4))
    actuators = tuple(tendons(base, model))
    # Open: thumb rotation at its opposed stop, every bending tendon at zero length; closed: all at the top.
    highs = mj.actuator_ctrlrange[:, 1].copy()
    lows = np.where(np.array(actuators) == "thumb_rotation", highs, 0.0)
    return Hand(
        name=name, kind="dexterous", build_spec=lambda: _spec(model, tcp), root_body=model.root_body,
        tcp_site=build.TCP_SITE,
        finger_bodies=(model.thumb_body, *(model.finger_body.format(f=f) for f in FINGERS)),
        actuators=actuators, open_ctrl=lows, closed_ctrl=highs, max_width=min(depth, span),
        max_grip_force=grip, mass=build.total_mass(mj), source="robosuite",
        fingertip_geoms=fingertip_geoms(base, model),
        notes=load_gripper_spec(model.xml)[1] + _mass_note(model) + _thumb_note(model) + (
            "12/11 per-joint servos replaced by 6 tendon servos: thumb rotation, thumb bend, index, middle, ring, "
            "pinky (coefficients proportional to joint ranges)"
            + ("; each finger's joints coupled in that proportion (a linkage)" if model.coupled
               else "; adaptive when a phalanx is blocked"),
            "thumb rotation re-referenced so qpos0 is the open pre-shape (thumb opposed, fingers straight)",
            f"armature {model.armature:g} kg m^2 on every finger joint (none in robosuite): with 1e-5 kg m^2 links "
            "the tendon forces pushed joints up to 1.2 rad through their (soft) stops",
            "fingertip forces at the force limits (F = f |c|^2 / |J c|, open pose): "
            + ", ".join(f"{k} {v:.1f} N" for k, v in forces.items())
            + "; max_grip_force = min(thumb, sum of the four fingers): the squeeze a thumb-vs-fingers "
            "opposition sustains, the largest grip force (manigrasp.sim.grip_force: thumb vs the rest of the "
            "hand) that GripController sets and holds; a raw full-synergy command is not force-regulated: once "
            "the thumb folds onto its joint stops, the stops carry the fingers' push and the squeeze can exceed it",
            f"open cavity: {1000 * depth:.0f} mm deep (palm to thumb tip), {1000 * span:.0f} mm across "
            "(thumb underside to shortest fingertip); max_width is the smaller",
            "finger bodies: one per finger (thumb first), the first bending link, whose subtree is the whole "
            "finger; listing two phalanges of one finger would let one finger count as two; the palm is not a "
            "finger",
            FINGERTIP_COVER[name.split("_")[0]],
        ))


def _mass_note(model: FiveFingerModel) -> tuple[str, ...]:
    if model.link_mass is None:
        return ()
    return (f"every link set to {model.link_mass} kg like the mirrored robosuite model (this file gives 0.5 kg)",)


def _thumb_note(model: FiveFingerModel) -> tuple[str, ...]:
    if model.thumb_frame is None:
        return ()
    return (f"thumb pitch joint frame {model.thumb_frame} (pos, quat): the mirror of the right hand's; robosuite's "
            "left thumb flexes in a plane tilted 6.5 deg from the mirror of the right's",)


def make_inspire_right() -> Hand:
    """robosuite's Inspire right hand (GR1)."""
    return make("inspire_right")


def make_inspire_left() -> Hand:
    """robosuite's Inspire left hand (GR1)."""
    return make("inspire_left")


def make_fourier_right() -> Hand:
    """robosuite's Fourier right hand (GR1)."""
    return make("fourier_right")


def make_fourier_left() -> Hand:
    """robosuite's Fourier left hand (GR1)."""
    return make("fourier_left")
