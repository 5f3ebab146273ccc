"""Small MjSpec editing helpers shared by the robosuite hands.

Poses handed to these helpers are in the frame of the stand-alone hand model
(its worldbody), where the root body sits at its own pos/quat; they are
converted to the root body's local frame here.
"""

from __future__ import annotations

from collections.abc import Sequence

import mujoco
import numpy as np

TCP_SITE = "tcp"


def quat_from_axes(y_axis: Sequence[float], z_axis: Sequence[float]) -> np.ndarray:
    """Quaternion (w, x, y, z) of the frame with the given y and z axes (x = y cross z)."""
    y = np.asarray(y_axis, float) / np.linalg.norm(y_axis)
    z = np.asarray(z_axis, float) / np.linalg.norm(z_axis)
    if abs(float(y @ z)) > 1e-6:
        raise ValueError("y and z axes must be orthogonal")
    mat = np.column_stack([np.cross(y, z), y, z])
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, mat.ravel())
    return quat


def add_tcp_site(spec: mujoco.MjSpec, root_body: str, pos: Sequence[float], quat: Sequence[float]) -> None:
    """Add the TCP site to `root_body`; `pos` [m] and `quat` are given in the hand model's world frame."""
    body = spec.body(root_body)
    inv = np.zeros(4)
    mujoco.mju_negQuat(inv, np.asarray(body.quat, float))
    local_pos = np.zeros(3)
    mujoco.mju_rotVecQuat(local_pos, np.asarray(pos, float) - np.asarray(body.pos, float), inv)
    local_quat = np.zeros(4)
    mujoco.mju_mulQuat(local_quat, inv, np.asarray(quat, float))
    body.add_site(name=TCP_SITE, pos=local_pos, quat=local_quat, size=[0.005, 0.005, 0.005],
                  rgba=[1.0, 0.0, 0.0, 0.5], group=3)


# A coupling must stay rigid under contact loads of ~100 N on links of a few grams. A soft
# constraint's steady violation scales with (1 - d) / d times the inverse effective mass, so
# the impedance d is pushed close to 1 (MuJoCo's default 0.95 lets a 2F-85 inner finger
# turn 0.3 rad away from its mimic angle under an 85 N grip).
COUPLING_SOLREF = (0.004, 1.0)
COUPLING_SOLIMP = (0.999, 0.9999, 0.001, 0.5, 2.0)


def couple_joints(spec: mujoco.MjSpec, follower: str, leader: str, ratio: float) -> None:
    """Equality q_follower = ratio * q_leader (a mimic joint of a rigid linkage)."""
    data = np.zeros(12)
    data[1] = ratio
    spec.add_equality(name=f"couple_{follower}", type=mujoco.mjtEq.mjEQ_JOINT, name1=follower, name2=leader,
                      data=data, solref=list(COUPLING_SOLREF), solimp=list(COUPLING_SOLIMP))


def add_tendon_position_actuator(spec: mujoco.MjSpec, name: str, joints: dict[str, float], kp: float,
                                 force_limit: float, ctrlrange: tuple[float, float]) -> None:
    """A fixed tendon sum(coef * q) over `joints` driven by a force-limited, critically damped position servo.

    `force_limit` is the largest tendon force [N or N m]; `ctrlrange` is in tendon-length units.
    """
    tendon = spec.add_tendon(name=name)
    for joint, coef in joints.items():
        tendon.wrap_joint(joint, coef)
    actuator = spec.add_actuator(name=name, target=name, trntype=mujoco.mjtTrn.mjTRN_TENDON)
    actuator.set_to_position(kp=kp, dampratio=1.0)
    actuator.ctrllimited = 1
    actuator.ctrlrange = list(ctrlrange)
    actuator.forcelimited = 1
    actuator.forcerange = [-force_limit, force_limit]


def delete_all(spec: mujoco.MjSpec, elements: Sequence[object]) -> None:
    """Delete every element of `elements` (e.g. ``spec.actuators``) from the spec."""
    for element in list(elements):
        spec.delete(element)


def set_joint_dynamics(spec: mujoco.MjSpec, joint: str, damping: float, armature: float) -> None:
    """Set a joint's viscous damping [N m s/rad or N s/m] and armature [kg m^2 or kg]."""
    spec.joint(joint).damping = [damping, 0.0, 0.0]
    spec.joint(joint).armature = armature


def total_mass(model: mujoco.MjModel) -> float:
    """Mass of everything below the world body [kg]."""
    return float(model.body_subtreemass[0])


def set_joint_default(spec: mujoco.MjSpec, joint: str, value: float) -> None:
    """Make `value` the joint's default position (qpos0) without moving the geometry's meaning.

    The joint's body is moved to where it sits at `value` and the joint's `ref`
    is set to `value`, so q keeps its meaning (limits unchanged) and qpos0 = value.
    """
    spec_joint = spec.joint(joint)
    body = spec_joint.parent
    axis = np.asarray(spec_joint.axis, float) / np.linalg.norm(spec_joint.axis)
    rot = np.asarray(body.quat, float) / np.linalg.norm(body.quat)
    offset = np.zeros(3)
    if spec_joint.type == mujoco.mjtJoint.mjJNT_SLIDE:
        mujoco.mju_rotVecQuat(offset, axis * value, rot)
        body.pos = np.asarray(body.pos, float) + offset
    elif spec_joint.type == mujoco.mjtJoint.mjJNT_HINGE:
        turn = np.zeros(4)
        mujoco.mju_axisAngle2Quat(turn, axis, value)
        anchor = np.asarray(spec_joint.pos, float)
        turned = np.zeros(3)
        mujoco.mju_rotVecQuat(turned, anchor, turn)
        mujoco.mju_rotVecQuat(offset, anchor - turned, rot)
        body.pos = np.asarray(body.pos, float) + offset
        new = np.zeros(4)
        mujoco.mju_mulQuat(new, rot, turn)
        body.quat = new
    else:
        raise ValueError(f"joint {joint!r}: only hinge and slide joints can be re-referenced")
    spec_joint.ref = value


def subtree_bodies(mj: mujoco.MjModel, root: str) -> set[int]:
    """Ids of body `root` and every body below it in the compiled model `mj`."""
    top = mj.body(root).id
    out = {top}
    for body in range(top + 1, mj.nbody):  # MuJoCo numbers a body after its parent
        if mj.body_parentid[body] in out:
            out.add(body)
    return out
