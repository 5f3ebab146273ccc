"""The two parallel-jaw grippers that ship with robosuite: Franka Panda hand and Robotiq 2F-85.

Both get one actuator driving both jaws, a TCP site between the pads
(z = approach, y = closing from finger 1 toward finger 2), and a closed
command past the closed stop so a jaw blocked by an object of any width
pushes at the actuator's force limit.
"""

from __future__ import annotations

import mujoco
import numpy as np

from manigrasp.hands.base import Hand
from manigrasp.hands.from_robosuite import build
from manigrasp.hands.from_robosuite.measure import jaw_gap
from manigrasp.hands.from_robosuite.source import load_gripper_spec

# --- Panda --------------------------------------------------------------------------------------
# robosuite's two independent position servos (20 N each) become one servo on the
# tendon `fingers` = q1 - q2 (the jaw opening, 0 to 8 cm) with q2 = -q1 enforced
# by an equality, as in the real hand where one motor drives both fingers. The tendon
# force is the push of each pad, so the grip force equals the actuator force limit:
# 70 N, the Franka hand's rated continuous force.
PANDA_GRIP_FORCE = 70.0  # [N]
PANDA_KP = 2000.0  # [N/m]
PANDA_STROKE = 0.08  # [m], tendon length when open
PANDA_TCP_POS = (0.0, 0.0, 0.0934)  # [m], centre of the pad boxes, hand-model frame


def panda_spec() -> mujoco.MjSpec:
    """A fresh spec of robosuite's Panda hand with manigrasp's actuator and TCP."""
    spec, _ = load_gripper_spec("panda_gripper.xml")
    build.delete_all(spec, spec.actuators)
    build.couple_joints(spec, "finger_joint2", "finger_joint1", -1.0)
    # At the closed stop the pad boxes overlap the other finger by 1 mm; jaws never touch each other.
    for body1 in ("leftfinger", "finger_joint1_tip"):
        for body2 in ("rightfinger", "finger_joint2_tip"):
            spec.add_exclude(bodyname1=body1, bodyname2=body2)
    past_closed = PANDA_GRIP_FORCE / PANDA_KP
    build.add_tendon_position_actuator(
        spec, "fingers", {"finger_joint1": 1.0, "finger_joint2": -1.0}, kp=PANDA_KP,
        force_limit=PANDA_GRIP_FORCE, ctrlrange=(-past_closed, PANDA_STROKE))
    # Finger 1 (leftfinger) sits at +y of the model, finger 2 at -y: closing is -y.
    build.add_tcp_site(spec, "right_gripper", PANDA_TCP_POS, build.quat_from_axes((0, -1, 0), (0, 0, 1)))
    return spec


def make_panda() -> Hand:
    """robosuite's Franka Panda hand as a manigrasp `Hand`."""
    spec = panda_spec()
    model = spec.compile()
    data = mujoco.MjData(model)
    _set_joints(model, data, {"finger_joint1": 0.04, "finger_joint2": -0.04})
    return Hand(
        name="panda", kind="parallel", build_spec=panda_spec, root_body="right_gripper",
        tcp_site=build.TCP_SITE, finger_bodies=("leftfinger", "rightfinger"), actuators=("fingers",),
        open_ctrl=np.array([PANDA_STROKE]), closed_ctrl=np.array([-PANDA_GRIP_FORCE / PANDA_KP]),
        max_width=jaw_gap(model, data, build.TCP_SITE).width, max_grip_force=PANDA_GRIP_FORCE,
        grip_stiffness=PANDA_KP * (PANDA_STROKE + PANDA_GRIP_FORCE / PANDA_KP),  # kp x span [N per synergy]
        mass=build.total_mass(model), source="robosuite",
        pad_geoms=("finger1_pad_collision", "finger2_pad_collision"),
        notes=load_gripper_spec("panda_gripper.xml")[1] + (
            "two 20 N finger servos replaced by one 70 N servo on the opening q1 - q2, fingers coupled "
            "by an equality (one motor drives both in the real hand)",
            "grip force = tendon force limit (each pad pushes with the tendon force)",
            "closed command is 3.5 cm past the closed stop so a blocked jaw saturates at 70 N at any width",
            "TCP at the centre of the two finger pads; finger 1 = leftfinger",
            "contacts between the two fingers excluded (their pads overlap by 1 mm at the closed stop)",
            "compliant pads: the finger hulls, 0.4-1.25 mm behind the 8 mm pads, are cut 6.0 mm back to the "
            "elements' 6.4 mm travel, their outer faces kept (`hands.pads.clear_backing`), so the pads, not the "
            "hulls, carry the grip",
        ))


# --- Robotiq 2F-85 ------------------------------------------------------------------------------
# Each finger is a four-bar linkage: base, outer knuckle (driven), inner finger
# (carries the pad), inner knuckle. It is a parallelogram: the inner knuckle's
# distal end stays at one point of the inner finger for every driver angle, which
# is what the joint couplings below encode (inner knuckle = driver, inner finger =
# -driver, as the URDF's mimic joints do), so the pads stay parallel. robosuite
# instead ties them with springy tendons (stiffness 0.4) that let the fingers sag.
# Both drivers are coupled (one motor in the real gripper) and one servo drives the
# tendon `fingers` = (q_left + q_right) / 2 [rad], 0 open to 0.8 closed.
ROBOTIQ_TORQUE = 10.0  # [N m], tendon force limit (5 N m on each driver)
ROBOTIQ_KP = 50.0  # [N m/rad]
ROBOTIQ_CLOSED = 0.8  # [rad], driver angle at the closed stop
ROBOTIQ_TCP_POS = (0.0, 0.0, 0.137)  # [m]; pad centres travel from z = 0.130 (open) to 0.144 (closed)
_ROBOTIQ_COUPLINGS = (
    ("left_inner_knuckle_joint", "finger_joint", 1.0),
    ("left_inner_finger_joint", "finger_joint", -1.0),
    ("right_outer_knuckle_joint", "finger_joint", 1.0),
    ("right_inner_knuckle_joint", "right_outer_knuckle_joint", 1.0),
    ("right_inner_finger_joint", "right_outer_knuckle_joint", -1.0),
)
_ROBOTIQ_LINKAGE_EXCLUDES = (
    ("left_inner_knuckle", "left_outer_knuckle"), ("left_inner_knuckle", "left_inner_finger"),
    ("right_inner_knuckle", "right_outer_knuckle"), ("right_inner_knuckle", "right_inner_finger"),
)


def robotiq_spec() -> mujoco.MjSpec:
    """A fresh spec of robosuite's Robotiq 2F-85 with a working linkage, one actuator and a TCP."""
    spec, _ = load_gripper_spec("robotiq_gripper_85.xml")
    build.delete_all(spec, spec.tendons)
    build.delete_all(spec, spec.actuators)
    for follower, leader, ratio in _ROBOTIQ_COUPLINGS:
        build.couple_joints(spec, follower, leader, ratio)
    for body1, body2 in _ROBOTIQ_LINKAGE_EXCLUDES:
        spec.add_exclude(bodyname1=body1, bodyname2=body2)
    for driver in ("finger_joint", "right_outer_knuckle_joint"):
        build.set_joint_dynamics(spec, driver, damping=0.5, armature=0.005)
    past_closed = ROBOTIQ_TORQUE / ROBOTIQ_KP
    build.add_tendon_position_actuator(
        spec, "fingers", {"finger_joint": 0.5, "right_outer_knuckle_joint": 0.5}, kp=ROBOTIQ_KP,
        force_limit=ROBOTIQ_TORQUE, ctrlrange=(0.0, ROBOTIQ_CLOSED + past_closed))
    # Finger 1 (left) sits at -y of the model, finger 2 at +y: closing is +y.
    build.add_tcp_site(spec, "robotiq_85_adapter_link", ROBOTIQ_TCP_POS, build.quat_from_axes((0, 1, 0), (0, 0, 1)))
    return spec


def robotiq_pose(model: mujoco.MjModel, data: mujoco.MjData, driver: float) -> None:
    """Put the linkage at driver angle `driver` [rad] (all couplings satisfied) and update kinematics."""
    values = {"finger_joint": driver}
    for follower, leader, ratio in _ROBOTIQ_COUPLINGS:
        values[follower] = ratio * values.get(leader, driver)
    _set_joints(model, data, values)


def robotiq_pad_speed(model: mujoco.MjModel, data: mujoco.MjData, driver: float, step: float = 1e-4) -> float:
    """|d y_pad / d q_driver| [m/rad] of the left pad at driver angle `driver` (finite difference)."""
    pad = model.geom("left_fingerpad_collision").id
    robotiq_pose(model, data, driver + step)
    y_plus = data.geom_xpos[pad, 1]
    robotiq_pose(model, data, driver - step)
    y_minus = data.geom_xpos[pad, 1]
    return abs(float(y_plus - y_minus)) / (2 * step)


def robotiq_grip_force_range(model: mujoco.MjModel, data: mujoco.MjData) -> tuple[float, float]:
    """Smallest and largest pad force [N] at the tendon force limit over the stroke.

    Virtual work with both fingers symmetric: tendon force f times the tendon
    change dq equals 2 F dy, so F = f / (2 |dy/dq|).
    """
    speeds = [robotiq_pad_speed(model, data, q) for q in np.linspace(0.0, ROBOTIQ_CLOSED, 17)]
    return ROBOTIQ_TORQUE / (2 * max(speeds)), ROBOTIQ_TORQUE / (2 * min(speeds))


def make_robotiq_2f85() -> Hand:
    """robosuite's Robotiq 2F-85 as a manigrasp `Hand`."""
    spec = robotiq_spec()
    model = spec.compile()
    data = mujoco.MjData(model)
    force_closed, force_open = robotiq_grip_force_range(model, data)
    robotiq_pose(model, data, 0.0)
    return Hand(
        name="robotiq_2f85", kind="parallel", build_spec=robotiq_spec, root_body="robotiq_85_adapter_link",
        tcp_site=build.TCP_SITE, finger_bodies=("left_outer_knuckle", "right_outer_knuckle"),
        actuators=("fingers",), open_ctrl=np.array([0.0]),
        closed_ctrl=np.array([ROBOTIQ_CLOSED + ROBOTIQ_TORQUE / ROBOTIQ_KP]),
        max_width=jaw_gap(model, data, build.TCP_SITE).width, max_grip_force=force_closed,
        mass=build.total_mass(model), source="robosuite",
        pad_geoms=("left_fingerpad_collision", "right_fingerpad_collision"),
        pad_backing=("left_fingertip_collision", "right_fingertip_collision"),
        notes=load_gripper_spec("robotiq_gripper_85.xml")[1] + (
            "four-bar linkage closed by joint couplings (inner knuckle = driver, inner finger = -driver; "
            "a parallelogram, pads stay parallel) instead of robosuite's springy tendons",
            "both drivers coupled, one 10 N m servo on (q_left + q_right) / 2",
            f"grip force at the force limit: {force_closed:.0f} N near closed to {force_open:.0f} N fully open "
            "(F = f / (2 |dy_pad/dq|)); max_grip_force is the value every width reaches",
            "finger = outer knuckle subtree (outer finger, inner finger, pad); inner knuckles are linkage bars",
            "TCP between the pads at mid-stroke height: pad centres move 1.4 cm along z over the stroke",
            "compliant pads: the 2 mm pad boxes become elastic foundations; the fingertip blocks 0.3 mm "
            "behind them stop colliding (the elements bottom out at 1.6 mm instead)",
        ))


def _set_joints(model: mujoco.MjModel, data: mujoco.MjData, values: dict[str, float]) -> None:
    for joint, value in values.items():
        data.qpos[model.jnt_qposadr[model.joint(joint).id]] = value
    mujoco.mj_kinematics(model, data)
