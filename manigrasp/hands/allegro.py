"""The Allegro hand (Wonik Robotics, v4): 16 joints, each with its own motor, read from `example-robot-data`.

An optional extra (``make setup EXTRAS=dev,allegro``, example-robot-data==6.0.0): the URDF and meshes of
``allegro_hand_description`` are read from the installed package and loaded by MuJoCo's URDF parser; these
fixes are applied at load (each is recorded in the hand's notes):

- mesh paths (``package://example-robot-data/...``) made absolute; visual meshes kept, visual only (MuJoCo's
  URDF import puts them in group 1 with no collision); the URDF's collision geometry (a box per link, a 12 mm
  sphere per fingertip) is what touches;
- ``balanceinertia``: the distal links' URDF inertias violate the triangle inequality (MuJoCo refuses them);
- joint friction and damping: the URDF's 5-12 N m of Coulomb friction and 3-10 N m s/rad of damping per joint
  are an order of magnitude above what the 0.7 N m motors could move; replaced by MuJoCo Menagerie's
  ``wonik_allegro`` damping (0.1 N m s/rad) and no friction loss; every joint gets an armature (`ARMATURE`)
  for rotor inertia so 0.7 N m cannot push a 1e-6 kg m^2 link through its (soft) joint stop;
- actuators (the URDF has none): one force-limited position servo per joint, ``forcerange`` +-`TORQUE`
  (the Allegro Hand v4 datasheet's maximum joint torque, 0.7 N m); the bending joints' servos are soft (`KP`)
  so a blocked joint's torque grows over 0.7 rad of command and the synergy can regulate the grip
  (`manigrasp.control.GripController`); the finger spread joints and the thumb's rotation and roll, which
  hold the pre-shape and take no part in the squeeze, are stiff (`HOLD_KP`);
- each distal link's collision box ends where the link's own mesh ends (`DISTAL_END`, as MuJoCo Menagerie's
  wonik_allegro has it), not at the fingertip sphere's centre: the URDF's box ran on over the first half of the
  fingertip ball and, 27.6 mm wide against the ball's 24 mm, put its bare edges in front of the rubber tip as soon
  as a fingertip contact tilted 10 deg sideways (`AllegroModel.trim_distal`; on the dexterous config's 7 objects x
  10, `standard` at 10 N, dexopt, seeds 0 and 1: 40 -> 41 and 43 -> 47/70, within noise);
- palm-finger self-collisions excluded (the knuckle links overlap the palm box, as in MuJoCo Menagerie);
- the thumb's rotation and roll joints are re-referenced so that the model's default configuration (qpos0) is
  the open pre-shape (the URDF's zero lies outside the rotation joint's range).

Frames (the stand-alone model's world frame, right hand): the palm faces +x, fingers point +z, the index finger
sits at +y (at -y for the left hand), the thumb's base below the palm (-z). TCP: z (approach) = +x, the palm
normal; y (closing, from the thumb toward the fingertips) = +z; x = y cross z runs across the palm, the axis of
a can held in a power grasp. The TCP is the axis of a cylinder of radius depth / 3 resting against the palm and
the opposed thumb (depth: palm front to the open thumb's tip along x; see `cavity`), across the palm where the
thumb's tip meets the fingers at mid-bend (between middle and ring finger); `max_width` is that diameter.

Synergy: open = fingers straight and spread at zero, thumb rotated into opposition (its rotation joint at its
upper stop) and rolled by `THUMB_ROLL`; closed = every bending joint commanded `TORQUE / KP` past its upper stop
(a blocked joint pushes at its torque limit); the spread, rotation and roll commands stay put.
"""

from __future__ import annotations

import importlib.metadata
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from manigrasp.errors import HandError
from manigrasp.hands.base import Hand
from manigrasp.hands.from_robosuite import build

DISTRIBUTION = "example-robot-data"
VERSION = "6.0.0"
EXTRA_HINT = ("in the manigrasp clone run `make setup EXTRAS=dev,allegro` (or `.venv/bin/pip install -c "
              f"constraints.txt -e '.[allegro]'`, which installs {DISTRIBUTION}=={VERSION})")
_DESCRIPTION = "cmeel.prefix/share/example-robot-data/robots/allegro_hand_description"
_PACKAGE_URL = "package://example-robot-data/robots/allegro_hand_description/meshes/"

# Largest joint torque [N m]: Wonik Robotics, Allegro Hand v4 specifications ("max joint torque 0.70 Nm").
TORQUE = 0.7
# Servo stiffness of the bending joints [N m/rad] (MuJoCo Menagerie wonik_allegro: position kp="1"). On the
# hand-placed can, 0.5 and 1 both settle on the set grip force (within 0.01 N); 1 holds the grasp's joints stiffer.
KP = 1.0
# Servo stiffness of the joints that hold the pre-shape (finger spread, thumb rotation and roll) [N m/rad].
HOLD_KP = 20.0
# Joint damping [N m s/rad] (MuJoCo Menagerie wonik_allegro) and reflected rotor inertia [kg m^2].
DAMPING = 0.1
ARMATURE = 1e-2
# Joint-stop constraint time constant [s] (MuJoCo solref_limit; its default is 0.02): the bending servos press
# their 0.7 N m into the stops, which the default lets the joints pass by 1 degree.
LIMIT_TIMECONST = 0.005
# Thumb roll (joint 13) of the pre-shape [rad]: the bending thumb then meets an object in the cavity between the
# middle and ring fingers (its tip at y = -0.02 m at mid-bend), the middle of the four fingertips' span.
THUMB_ROLL = 0.9

ROOT_BODY = "palm_link"
FINGERS = ("index", "middle", "ring")
_FINGER_BASE = {"index": 0, "middle": 4, "ring": 8}  # first joint number of each finger
THUMB_ROTATION, THUMB_ROLL_JOINT = "joint_12.0", "joint_13.0"
SPREAD = tuple(f"joint_{_FINGER_BASE[f]}.0" for f in FINGERS)
BENDING = {**{f: tuple(f"joint_{_FINGER_BASE[f] + i}.0" for i in (1, 2, 3)) for f in FINGERS},
           "thumb": ("joint_14.0", "joint_15.0")}
TIPS = {**{f: f"link_{_FINGER_BASE[f] + 3}.0_tip" for f in FINGERS}, "thumb": "link_15.0_tip"}
# Where each distal link's own mesh ends along the link [m] (link_3.0.STL and link_15.0.STL reach z = 15.7 and
# 31.3 mm; MuJoCo Menagerie's wonik_allegro distal_collision boxes end at 16 and 31.4 mm): the fingertip sphere
# (link_*_tip.STL, a 24 mm ball centred at 26.7 and 42.3 mm) follows. The URDF's collision box runs on to the ball's
# centre and is wider (27.6 mm) than the ball (24 mm); see `_trim_distal`.
DISTAL_END = {"finger": 0.0157, "thumb": 0.0313}
# The fingertips' 12 mm collision spheres, named at load (thumb first). With `pads: compliant` they touch with the pad
# rubber's friction (`SceneConfig.pad_friction`): the Allegro's fingertips are the white rounded caps at the end of
# each finger, described as rubber-covered by users and papers, but no manufacturer statement of their material
# was found; the links behind them are bare aluminium and plastic and keep the hand's friction.
FINGERTIP_GEOMS = {f: f"{TIPS[f]}_collision" for f in ("thumb", *FINGERS)}
FINGERTIP_COVER = ("fingertips: the 12 mm tip spheres (link_*_tip_collision) stand for the Allegro's rounded fingertip "
                   "caps; their rubber covering is not sourced (no manufacturer statement found); with pads: "
                   "compliant they touch with the pad rubber's friction (pad_friction), the links keep the hand's")


@dataclass(frozen=True)
class AllegroModel:
    """One side of the Allegro hand and the parameters of its actuation."""

    name: str
    urdf: str
    torque: float = TORQUE
    kp: float = KP
    hold_kp: float = HOLD_KP
    damping: float = DAMPING
    armature: float = ARMATURE
    thumb_roll: float = THUMB_ROLL
    trim_distal: bool = True  # end the distal collision boxes at `DISTAL_END` (False: the URDF's, as before 4 Dec 2026)


MODELS = {f"allegro_{side}": AllegroModel(f"allegro_{side}", f"allegro_{side}_hand.urdf")
          for side in ("right", "left")}


def description_dir() -> Path:
    """Folder of ``allegro_hand_description`` in the installed example-robot-data package."""
    try:
        dist = importlib.metadata.distribution(DISTRIBUTION)
    except importlib.metadata.PackageNotFoundError:
        raise HandError(f"the Allegro hand needs the 'allegro' extra: {EXTRA_HINT}") from None
    folder = Path(str(dist.locate_file(_DESCRIPTION)))
    if not (folder / "urdf").is_dir():
        raise HandError(f"{DISTRIBUTION} {dist.version} is installed but has no {_DESCRIPTION} ({EXTRA_HINT})")
    return folder


def _urdf_text(model: AllegroModel) -> str:
    folder = description_dir()
    path = folder / "urdf" / model.urdf
    if not path.is_file():
        raise HandError(f"Allegro URDF not found: {path} ({EXTRA_HINT})")
    text = path.read_text().replace(_PACKAGE_URL, str(folder / "meshes") + "/")
    compiler = ('<mujoco><compiler discardvisual="false" strippath="false" fusestatic="false" '
                'balanceinertia="true"/></mujoco>')
    head, sep, tail = text.partition("<robot ")
    close = tail.index(">") + 1
    return head + sep + tail[:close] + compiler + tail[close:]


def _actuate(spec: mujoco.MjSpec, model: AllegroModel) -> None:
    """Damping, armature, no friction loss; one force-limited position servo per joint."""
    bending = {joint for chain in BENDING.values() for joint in chain}
    for joint in spec.joints:
        joint.damping = [model.damping, 0.0, 0.0]
        joint.frictionloss = 0.0
        joint.armature = model.armature
        joint.solref_limit = [LIMIT_TIMECONST, 1.0]
    for joint in sorted((j.name for j in spec.joints), key=_joint_number):
        low, high = (float(v) for v in spec.joint(joint).range)
        soft = joint in bending
        top = high + model.torque / model.kp if soft else high
        actuator = spec.add_actuator(name=joint, target=joint, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        actuator.set_to_position(kp=model.kp if soft else model.hold_kp, dampratio=1.0)
        actuator.ctrllimited = 1
        actuator.ctrlrange = [low, top]
        actuator.forcelimited = 1
        actuator.forcerange = [-model.torque, model.torque]


def _joint_number(name: str) -> float:
    return float(name.removeprefix("joint_"))


def _exclude_palm(spec: mujoco.MjSpec) -> None:
    for body in ("link_0.0", "link_1.0", "link_4.0", "link_5.0", "link_8.0", "link_9.0", "link_12.0",
                 "link_13.0", "link_14.0"):
        spec.add_exclude(bodyname1=ROOT_BODY, bodyname2=body)


def _name_fingertips(spec: mujoco.MjSpec) -> None:
    """Name each fingertip's collision sphere (the URDF's geoms have no names) `FINGERTIP_GEOMS`."""
    for finger, geom_name in FINGERTIP_GEOMS.items():
        spheres = [g for g in spec.body(TIPS[finger]).geoms
                   if (g.contype or g.conaffinity) and g.type == mujoco.mjtGeom.mjGEOM_SPHERE]
        if len(spheres) != 1:
            raise HandError(f"Allegro fingertip {TIPS[finger]!r}: expected one collision sphere, got {len(spheres)}")
        spheres[0].name = geom_name


def _trim_distal(spec: mujoco.MjSpec) -> None:
    """End each distal link's collision box where the link's own mesh ends (`DISTAL_END`), short of its fingertip."""
    for finger, tip in TIPS.items():
        link = spec.body(tip).parent
        boxes = [g for g in link.geoms if (g.contype or g.conaffinity) and g.type == mujoco.mjtGeom.mjGEOM_BOX]
        if len(boxes) != 1:
            raise HandError(f"Allegro distal link {link.name!r}: expected one collision box, got {len(boxes)}")
        half = DISTAL_END["thumb" if finger == "thumb" else "finger"] / 2
        boxes[0].size = [boxes[0].size[0], boxes[0].size[1], half]
        boxes[0].pos = [boxes[0].pos[0], boxes[0].pos[1], half]


def _base_spec(model: AllegroModel) -> mujoco.MjSpec:
    """The URDF with the fixes of the module docstring; no TCP yet."""
    spec = mujoco.MjSpec.from_string(_urdf_text(model))
    spec.compiler.degree = False
    spec.meshdir = ""
    _actuate(spec, model)
    _exclude_palm(spec)
    _name_fingertips(spec)
    if model.trim_distal:
        _trim_distal(spec)
    build.set_joint_default(spec, THUMB_ROTATION, float(spec.joint(THUMB_ROTATION).range[1]))
    build.set_joint_default(spec, THUMB_ROLL_JOINT, model.thumb_roll)
    return spec


def _spec(model: AllegroModel, tcp_pos: tuple[float, float, float]) -> mujoco.MjSpec:
    spec = _base_spec(model)
    build.add_tcp_site(spec, ROOT_BODY, tcp_pos, build.quat_from_axes((0, 0, 1), (1, 0, 0)))
    return spec


def open_ctrl(mj: mujoco.MjModel, model: AllegroModel) -> np.ndarray:
    """(16,) commands of the open pre-shape: straight fingers, thumb opposed and rolled."""
    ctrl = np.zeros(mj.nu)
    ctrl[mj.actuator(THUMB_ROTATION).id] = mj.jnt_range[mj.joint(THUMB_ROTATION).id, 1]
    ctrl[mj.actuator(THUMB_ROLL_JOINT).id] = model.thumb_roll
    return np.clip(ctrl, mj.actuator_ctrlrange[:, 0], mj.actuator_ctrlrange[:, 1])


def closed_ctrl(mj: mujoco.MjModel, model: AllegroModel) -> np.ndarray:
    """(16,) commands of the closed shape: every bending joint at the top of its command range."""
    ctrl = open_ctrl(mj, model)
    for chain in BENDING.values():
        for joint in chain:
            act = mj.actuator(joint).id
            ctrl[act] = mj.actuator_ctrlrange[act, 1]
    return ctrl


def _points(mj: mujoco.MjModel, data: mujoco.MjData, bodies: set[int]) -> np.ndarray:
    """World points (n, 3) [m] bounding the collision geoms of `bodies`: box corners, sphere extremes."""
    chunks = []
    signs = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T
    for geom in range(mj.ngeom):
        if mj.geom_bodyid[geom] not in bodies or not (mj.geom_contype[geom] or mj.geom_conaffinity[geom]):
            continue
        rot, centre, size = data.geom_xmat[geom].reshape(3, 3), data.geom_xpos[geom], mj.geom_size[geom]
        if mj.geom_type[geom] == mujoco.mjtGeom.mjGEOM_BOX:
            chunks.append(centre + (signs * size) @ rot.T)
        elif mj.geom_type[geom] == mujoco.mjtGeom.mjGEOM_SPHERE:
            chunks.append(centre + size[0] * np.vstack([np.eye(3), -np.eye(3)]))
        else:
            raise HandError(f"Allegro collision geom {geom} of type {mj.geom_type[geom]} is not a box or sphere")
    return np.concatenate(chunks)


def cavity(mj: mujoco.MjModel, data: mujoco.MjData) -> tuple[np.ndarray, float, float]:
    """TCP position [m] in the open hand, the cavity's depth along +x and its span along +z [m] (at `data`'s pose).

    The TCP is the axis of a power-grasped cylinder of radius r = depth / 3 lying against the palm's front and
    the opposed thumb's top (so the thumb's tip reaches r past its far side, and the fingers close over it):
    x = palm front + r, z = thumb top + r; across the palm, where the thumb's tip meets the fingers at mid-bend.
    At the cavity's centre instead the fingers reached a 66 mm can with their tips only (it slid 1.4 cm in a
    10 cm lift, and a full close curled the fingers past the TCP); here it rests on the palm (0.4 mm).
    """
    palm = _points(mj, data, {mj.body(ROOT_BODY).id})
    thumb = _points(mj, data, build.subtree_bodies(mj, "link_13.0"))
    thumb_tip = _points(mj, data, {mj.body(TIPS["thumb"]).id})
    tips = [_points(mj, data, {mj.body(TIPS[f]).id}) for f in FINGERS]
    palm_front, thumb_reach = float(palm[:, 0].max()), float(thumb_tip[:, 0].max())
    thumb_top = float(thumb[:, 2].max())
    finger_reach = min(float(t[:, 2].max()) for t in tips)
    depth = thumb_reach - palm_front
    centre = np.array([palm_front + depth / 3, _thumb_meets(mj), thumb_top + depth / 3])
    return centre, depth, finger_reach - thumb_top


def _thumb_meets(mj: mujoco.MjModel) -> float:
    """y [m] of the thumb's tip with its bending joints at mid-range: where it meets an object in the cavity."""
    data = mujoco.MjData(mj)
    for joint in BENDING["thumb"]:
        data.qpos[mj.joint(joint).qposadr[0]] = float(np.mean(mj.jnt_range[mj.joint(joint).id]))
    mujoco.mj_kinematics(mj, data)
    return float(data.xpos[mj.body(TIPS["thumb"]).id, 1])


def tip_forces(mj: mujoco.MjModel, data: mujoco.MjData, torque: float) -> dict[str, float]:
    """Fingertip force [N] of each finger with its bending joints at `torque`, at `data`'s pose.

    Statics: joint torques tau = J^T F balance a force F at the fingertip sphere's centre; the least-squares
    F = pinv(J^T) tau, J the tip's translational Jacobian over the finger's bending joints.
    """
    jacp = np.zeros((3, mj.nv))
    out = {}
    for finger, chain in BENDING.items():
        body = mj.body(TIPS[finger]).id
        mujoco.mj_jac(mj, data, jacp, None, data.xpos[body], body)
        dofs = [mj.jnt_dofadr[mj.joint(j).id] for j in chain]
        out[finger] = float(np.linalg.norm(np.linalg.pinv(jacp[:, dofs].T) @ np.full(len(dofs), torque)))
    return out


def make(name: str) -> Hand:
    """The Allegro hand `name` (allegro_right or allegro_left)."""
    return make_from(MODELS[name])


def make_from(model: AllegroModel) -> Hand:
    """The `Hand` of an Allegro model description (e.g. one of `MODELS` with other gains)."""
    mj = _base_spec(model).compile()
    data = mujoco.MjData(mj)  # qpos0 is the open pre-shape
    ctrl_open = open_ctrl(mj, model)
    mujoco.mj_kinematics(mj, data)
    mujoco.mj_comPos(mj, data)
    centre, depth, span = cavity(mj, data)
    forces = tip_forces(mj, data, model.torque)
    grip = min(forces["thumb"], sum(forces[f] for f in FINGERS))
    tcp = tuple(float(v) for v in np.round(centre, 4))
    actuators = tuple(mj.actuator(i).name for i in range(mj.nu))
    return Hand(
        name=model.name, kind="dexterous", build_spec=lambda: _spec(model, tcp), root_body=ROOT_BODY,
        tcp_site=build.TCP_SITE, finger_bodies=("link_12.0", "link_0.0", "link_4.0", "link_8.0"),
        actuators=actuators, open_ctrl=ctrl_open, closed_ctrl=closed_ctrl(mj, model),
        max_width=min(2 * depth / 3, span / 2), max_grip_force=grip, mass=build.total_mass(mj),
        fingertip_geoms=tuple(FINGERTIP_GEOMS.values()),
        source=f"{DISTRIBUTION} {importlib.metadata.version(DISTRIBUTION)}",
        notes=(
            f"model: {DISTRIBUTION} allegro_hand_description/urdf/{model.urdf} (MuJoCo's URDF import)",
            "URDF joint friction (5-12 N m) and damping (3-10 N m s/rad) replaced by damping "
            f"{model.damping:g} N m s/rad (MuJoCo Menagerie) and armature {model.armature:g} kg m^2",
            f"16 position servos, torque limit {model.torque:g} N m (Allegro v4 datasheet); bending joints "
            f"kp {model.kp:g} N m/rad (soft: the grip is regulated through the synergy), spread, thumb rotation "
            f"and roll kp {model.hold_kp:g} N m/rad",
            "thumb rotation and roll re-referenced so qpos0 is the open pre-shape (thumb opposed and rolled)",
            "inertias balanced at load (the distal links' URDF inertias violate the triangle inequality); "
            "palm-knuckle collisions excluded",
            *(("distal links' collision boxes end where their meshes do (15.7 mm, thumb 31.3 mm; MuJoCo Menagerie "
               "likewise), short of the fingertip sphere (the URDF's ran on to its centre)",) if model.trim_distal
              else ()),
            "fingertip forces at the torque limit (F = pinv(J^T) tau, open pose): "
            + ", ".join(f"{k} {v:.1f} N" for k, v in forces.items())
            + "; max_grip_force = min(thumb, sum of the three fingers)",
            f"open cavity: {1000 * depth:.0f} mm deep (palm to thumb tip), {1000 * span:.0f} mm across "
            "(thumb top to shortest fingertip); TCP: the axis of a cylinder of radius depth/3 against palm and "
            "thumb; max_width = its diameter (the widest cylinder the open hand takes against its palm)",
            "finger bodies: thumb (link_12.0), index (link_0.0), middle (link_4.0), ring (link_8.0), each the "
            "first link of its finger, whose subtree is the whole finger",
            FINGERTIP_COVER,
        ))


def make_allegro_right() -> Hand:
    """The Allegro hand v4, right."""
    return make("allegro_right")


def make_allegro_left() -> Hand:
    """The Allegro hand v4, left."""
    return make("allegro_left")
