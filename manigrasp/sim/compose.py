"""Building the `MjSpec` of a scene: table + object + hand on a floating base.

Names are prefixed per part: ``table/``, ``object/`` (the object's body is
``object/object``), ``hand/`` (every element of the hand's own MJCF) and
``mount/`` (the six base joints, their motors and their servos). Everything
is later found by name, never by position.

The floating base (see `manigrasp.control` for why it is built this way): the
hand's root body hangs from the world by six joints placed on the root body
itself, in this order: slides ``mount/tx``, ``mount/ty``, ``mount/tz`` along
the axes of the TCP frame, then hinges ``mount/rx``, ``mount/ry``, ``mount/rz``
about the same axes through the hand's centre of mass (at its open pose).
Each joint carries two actuators:

- a ``motor`` of gear 1 named like the joint (``mount/tx``...): its command is
  the generalised force of that joint (`control.ImpedanceController`, a
  Cartesian law computed in Python every step);
- a ``general`` servo ``mount/tx_servo``... with gain kp and affine bias
  -kp q - kv qdot, i.e. the PD law kp (u - q) - kv qdot evaluated by MuJoCo
  every step (`control.NativeImpedance`). It is built with kp = kv = 0 (off);
  a controller sets the gains when it engages, `Scene.reset` switches them off.

At zero joint positions the TCP sits
exactly on the *mount* pose, which is moved between trials by editing the root
body's `body_pos`/`body_quat` in the compiled model: no recompilation.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from manigrasp.contact.defaults import STANDARD_ROLLING_M, STANDARD_TORSION_M
from manigrasp.errors import SimulationError
from manigrasp.hands import pads
from manigrasp.hands.base import Hand
from manigrasp.objects.asset import ObjectAsset
from manigrasp.sim.config import SceneConfig

BASE_JOINTS = ("mount/tx", "mount/ty", "mount/tz", "mount/rx", "mount/ry", "mount/rz")
BASE_SERVOS = tuple(f"{joint}_servo" for joint in BASE_JOINTS)
HAND_PREFIX = "hand/"
OBJECT_PREFIX = "object/"
OBJECT_BODY = "object/object"
TABLE_GEOM = "table/top"

ObjectSource = ObjectAsset | str | Path | mujoco.MjSpec


@dataclass(frozen=True)
class HandFrames:
    """Facts about a hand measured once on the hand alone (root fixed, no gravity).

    Attributes:
        tcp_in_root: (4, 4) pose of the TCP site in the root body frame.
        com_in_root: (3,) centre of mass of the open hand, root frame [m].
        open_qpos: hand joint name (unprefixed) -> (qpos,) of the open pre-shape.
    """

    tcp_in_root: np.ndarray
    com_in_root: np.ndarray
    open_qpos: dict[str, np.ndarray]


def measure_hand(hand: Hand, settle_time: float) -> HandFrames:
    """Compile `hand` alone, drive it open for `settle_time` [s] and measure its frames.

    The root body gets a free joint here (gravity off), as in the scene where it
    moves: a root welded to the world would not filter contacts between the
    palm and its own fingers (MuJoCo filters parent-child contacts only for
    moving parents). Measurements are in the root frame, so its drift does not
    matter. If the joints still move after `settle_time`, it runs up to 3 s more.
    """
    spec = hand.build_spec()
    root_spec = spec.body(hand.root_body)
    if root_spec is None:
        raise SimulationError(f"hand {hand.name!r}: root body {hand.root_body!r} not in its MJCF")
    root_spec.add_freejoint()
    model = compile_spec(spec, f"hand {hand.name!r}")
    model.opt.gravity[:] = 0.0
    data = mujoco.MjData(model)
    act = [name_to_id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, name, "actuator") for name in hand.actuators]
    data.ctrl[act] = hand.open_ctrl
    steps = int(round(settle_time / model.opt.timestep))
    for _ in range(steps):
        mujoco.mj_step(model, data)
    for _ in range(int(3.0 / model.opt.timestep)):
        if np.max(np.abs(data.qvel[6:]), initial=0.0) < 1e-4:
            break
        mujoco.mj_step(model, data)
    mujoco.mj_forward(model, data)
    root = name_to_id(model, mujoco.mjtObj.mjOBJ_BODY, hand.root_body, "body")
    site = name_to_id(model, mujoco.mjtObj.mjOBJ_SITE, hand.tcp_site, "site")
    rot_root = data.xmat[root].reshape(3, 3)
    tcp = np.eye(4)
    tcp[:3, :3] = rot_root.T @ data.site_xmat[site].reshape(3, 3)
    tcp[:3, 3] = rot_root.T @ (data.site_xpos[site] - data.xpos[root])
    com = rot_root.T @ (data.subtree_com[root] - data.xpos[root])
    open_qpos = {}
    for j in range(1, model.njnt):  # joint 0 is the free joint added above
        adr, width = model.jnt_qposadr[j], qpos_width(model.jnt_type[j])
        open_qpos[model.joint(j).name] = data.qpos[adr:adr + width].copy()
    return HandFrames(tcp_in_root=tcp, com_in_root=com, open_qpos=open_qpos)


def compose_spec(hand: Hand, frames: HandFrames, obj: ObjectSource | None,
                 config: SceneConfig) -> mujoco.MjSpec:
    """The scene's `MjSpec` (not compiled): physics options, table, object, hand on its base."""
    spec = mujoco.MjSpec()
    spec.modelname = f"manigrasp_{hand.name}"
    config.apply(spec.option)
    _add_table(spec, config)
    if obj is not None:
        _attach_object(spec, obj)
    _attach_hand(spec, hand, frames, config)
    return spec


def object_spec(obj: ObjectSource) -> mujoco.MjSpec:
    """A spec holding the object alone, attached as in a scene (no table, no hand)."""
    spec = mujoco.MjSpec()
    _attach_object(spec, obj)
    return spec


def tabletop_spec(obj: ObjectSource, config: SceneConfig) -> mujoco.MjSpec:
    """The `MjSpec` (not compiled) of the table and `obj` as in a scene, without a hand (`sim.tabletop`)."""
    spec = mujoco.MjSpec()
    spec.modelname = "manigrasp_tabletop"
    config.apply(spec.option)
    _add_table(spec, config)
    _attach_object(spec, obj)
    return spec


def _add_table(spec: mujoco.MjSpec, config: SceneConfig) -> None:
    half = np.asarray(config.table_half_extents, float)
    spec.worldbody.add_geom(name=TABLE_GEOM, type=mujoco.mjtGeom.mjGEOM_BOX, size=half,
                            pos=[0.0, 0.0, -half[2]],
                            friction=[config.table_friction, STANDARD_TORSION_M, STANDARD_ROLLING_M],
                            rgba=[0.55, 0.45, 0.35, 1.0])
    spec.worldbody.add_light(name="table/light", pos=[0.0, 0.0, 1.5], dir=[0.0, 0.0, -1.0])


def _attach_object(spec: mujoco.MjSpec, obj: ObjectSource) -> None:
    if isinstance(obj, mujoco.MjSpec):
        child = obj
    else:
        path = Path(obj.mjcf_path if isinstance(obj, ObjectAsset) else obj)
        if not path.is_file():
            raise SimulationError(f"object MJCF not found: {path}")
        child = mujoco.MjSpec.from_file(str(path))
    body = child.body("object")
    if body is None:
        found = [b.name for b in child.bodies if b.name]
        raise SimulationError(f"object MJCF has no body named 'object' (bodies: {', '.join(found) or 'none'})")
    spec.worldbody.add_frame().attach_body(body, OBJECT_PREFIX, "")


def _attach_hand(spec: mujoco.MjSpec, hand: Hand, frames: HandFrames, config: SceneConfig) -> None:
    child = hand_spec(hand, config)
    body = child.body(hand.root_body)
    if body is None:
        raise SimulationError(f"hand {hand.name!r}: root body {hand.root_body!r} not in its MJCF")
    root = spec.worldbody.add_frame().attach_body(body, HAND_PREFIX, "")
    if root.first_joint() is not None:
        raise SimulationError(f"hand {hand.name!r}: root body {hand.root_body!r} must have no joint")
    axes = frames.tcp_in_root[:3, :3]
    for i, name in enumerate(BASE_JOINTS):
        kind = mujoco.mjtJoint.mjJNT_SLIDE if i < 3 else mujoco.mjtJoint.mjJNT_HINGE
        # Every field explicit: the root body's childclass must not leak limits or damping in.
        root.add_joint(name=name, type=kind, axis=axes[:, i % 3], pos=frames.com_in_root,
                       limited=mujoco.mjtLimited.mjLIMITED_FALSE, actfrclimited=mujoco.mjtLimited.mjLIMITED_FALSE,
                       damping=[0.0], armature=0.0, frictionloss=0.0, stiffness=[0.0], margin=0.0,
                       group=4)
        spec.add_actuator(name=name, target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
    for joint, servo in zip(BASE_JOINTS, BASE_SERVOS, strict=True):
        spec.add_actuator(name=servo, target=joint, trntype=mujoco.mjtTrn.mjTRN_JOINT,
                          gaintype=mujoco.mjtGain.mjGAIN_FIXED, biastype=mujoco.mjtBias.mjBIAS_AFFINE,
                          gainprm=[0.0] * 10, biasprm=[0.0] * 10, ctrllimited=mujoco.mjtLimited.mjLIMITED_FALSE,
                          forcelimited=mujoco.mjtLimited.mjLIMITED_FALSE)
    _tune_hand_geoms(root, config, {HAND_PREFIX + name for name in rubber_fingertips(hand, config)})


def rubber_fingertips(hand: Hand, config: SceneConfig) -> tuple[str, ...]:
    """The hand's fingertip geoms (unprefixed) that touch with the pads' rubber friction in this scene: its
    `Hand.fingertip_geoms` with ``pads: compliant``, none with ``pads: rigid``."""
    return hand.fingertip_geoms if config.pads == "compliant" else ()


def hand_spec(hand: Hand, config: SceneConfig) -> mujoco.MjSpec:
    """A fresh spec of `hand` alone, its pads made compliant if `config.pads` asks for it."""
    child = hand.build_spec()
    if config.pads == "compliant" and hand.pad_geoms:
        # the pads' backing blocks stop colliding first, so `pads.clear_backing` leaves them as they are
        for name in hand.pad_backing:
            backing = child.geom(name)
            if backing is None:
                raise SimulationError(f"hand {hand.name!r}: pad backing geom {name!r} not in its MJCF")
            backing.contype, backing.conaffinity = 0, 0
        directions = pads.pad_directions(child, hand.pad_geoms, hand.tcp_site)
        pads.make_compliant(child, directions, config.pad_model())
    for name in rubber_fingertips(hand, config):
        geom = child.geom(name)
        if geom is None or (geom.contype == 0 and geom.conaffinity == 0):
            raise SimulationError(f"hand {hand.name!r}: fingertip geom {name!r} is not a colliding geom of its MJCF")
    return child


def _tune_hand_geoms(root: mujoco.MjsBody, config: SceneConfig, rubber: set[str]) -> None:
    """Hand-object friction, condim and priority on every colliding hand geom; gravcomp.

    Compliant pad elements keep what `manigrasp.hands.pads.make_compliant` gave them: the pads'
    rubber friction `config.pad_friction` and their cell's own torsional friction (condim 4).
    The geoms named in `rubber` (prefixed: a dexterous hand's rubber-covered fingertips, `rubber_fingertips`)
    get the rubber's sliding friction `config.pad_friction` and otherwise what every hand geom gets.
    """
    bodies = [root, *root.find_all(mujoco.mjtObj.mjOBJ_BODY)]
    for body in bodies:
        body.gravcomp = 1.0 if config.hand_gravcomp else 0.0
        for geom in body.geoms:
            if geom.contype == 0 and geom.conaffinity == 0:
                continue
            geom.priority = max(int(geom.priority), 1)
            if pads.is_element(geom.name.removeprefix(HAND_PREFIX)):
                continue  # friction and condim of the pad's rubber, set by pads.make_compliant
            sliding = config.pad_friction if geom.name in rubber else config.hand_friction
            geom.friction = [sliding, config.hand_torsional_friction, STANDARD_ROLLING_M]
            geom.condim = config.hand_condim


def compile_spec(spec: mujoco.MjSpec, what: str = "scene") -> mujoco.MjModel:
    """Compile `spec`, turning MuJoCo's error into a `SimulationError`."""
    try:
        return spec.compile()
    except ValueError as exc:
        raise SimulationError(f"{what} does not compile: {exc}") from exc


def qpos_width(jnt_type: int) -> int:
    """Number of qpos entries of a joint type (free 7, ball 4, slide/hinge 1)."""
    return {mujoco.mjtJoint.mjJNT_FREE: 7, mujoco.mjtJoint.mjJNT_BALL: 4}.get(int(jnt_type), 1)


def name_to_id(model: mujoco.MjModel, obj: mujoco.mjtObj, name: str, kind: str) -> int:
    """`mj_name2id`, raising `SimulationError` that lists the names of that kind if absent."""
    idx = mujoco.mj_name2id(model, obj, name)
    if idx < 0:
        count = {"body": model.nbody, "site": model.nsite, "actuator": model.nu, "joint": model.njnt,
                 "geom": model.ngeom}.get(kind, 0)
        names = [mujoco.mj_id2name(model, obj, i) for i in range(count)]
        raise SimulationError(f"no {kind} named {name!r}; available: {', '.join(n for n in names if n)}")
    return idx
