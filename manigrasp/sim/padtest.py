"""A pad pressed on a surface, closed loop in MuJoCo: the validation cases of the pad contact model.

One finger pad (the `parallel_jaw` pad: a 2 x 3 cm box, 6 mm thick) hangs
face-down from a carrier body that can slide along the pad normal (world z)
and turn about it; gravity is off. A constant force F pushes the carrier
down onto a fixed surface at z = 0 (a flat box, or a height field of bumps),
then a torque about the normal is ramped up slowly until the pad turns. The
normal force the surface returns and the torque at which the pad starts to
slip are what `press_pad` measures; `manigrasp.hands.pads.uniform_patch_torque`
is the value a uniform-pressure patch gives.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from manigrasp.contact.defaults import STANDARD_ROLLING_M
from manigrasp.control import ImpedanceController, default_gains
from manigrasp.hands import pads
from manigrasp.sim.compose import ObjectSource
from manigrasp.sim.config import SceneConfig
from manigrasp.sim.scene import Scene, build_scene

PAD_HALF = (0.01, 0.015, 0.003)  # [m], the parallel_jaw pad box (x, y in the face; z thickness)
SURFACE_HALF = 0.04  # [m], half side of the square surface
SLIP_SPEED = 0.05  # [rad/s], the pad counts as slipping once its mean speed over SLIP_WINDOW exceeds this
SLIP_WINDOW = 0.02  # [s]: a contact hopping between height-field prisms jolts the pad by < 1 mrad, not a slip


@dataclass(frozen=True)
class PressResult:
    """What a pressed pad measured.

    Attributes:
        normal_force: force of the surface on the pad along the press axis at rest (mean over 0.4-0.5 s) [N].
        holding_torque: largest torque about the normal before the pad slipped [N m].
        contacts: number of pad-surface contacts at rest.
    """

    normal_force: float
    holding_torque: float
    contacts: int


def bumps(n: int = 81, amplitude: float = 0.0005, wavelength: float = 0.03) -> np.ndarray:
    """(n, n) heights [m] of an egg-crate surface a cos(2 pi x / L) cos(2 pi y / L) over the square
    surface, crest under the pad centre: crest to trough 2 a (1 mm by default)."""
    grid = np.linspace(-SURFACE_HALF, SURFACE_HALF, n)
    x, y = np.meshgrid(grid, grid, indexing="xy")
    return amplitude * np.cos(2 * np.pi * x / wavelength) * np.cos(2 * np.pi * y / wavelength)


def pad_rig(mode: str, heights: np.ndarray | None = None, config: SceneConfig | None = None,
            half: tuple[float, float, float] = PAD_HALF) -> mujoco.MjModel:
    """The rig's model: `mode` "compliant" or "rigid" pad of half extents `half` (x, y in the face, z thickness
    [m]; default the `parallel_jaw` pad), over a flat surface or `heights` (n, n) [m]."""
    config = config or SceneConfig()
    spec = mujoco.MjSpec()
    config.apply(spec.option)
    spec.option.gravity = [0.0, 0.0, 0.0]
    top = 0.0
    if heights is None:
        spec.worldbody.add_geom(name="surface", type=mujoco.mjtGeom.mjGEOM_BOX,
                                size=[SURFACE_HALF, SURFACE_HALF, 0.01], pos=[0, 0, -0.01])
    else:
        low, high = float(heights.min()), float(heights.max())
        span = max(high - low, 1e-6)
        field = spec.add_hfield(name="bumps", nrow=heights.shape[0], ncol=heights.shape[1],
                                size=[SURFACE_HALF, SURFACE_HALF, span, 0.01])
        field.userdata = ((heights - low) / span).ravel().tolist()
        spec.worldbody.add_geom(name="surface", type=mujoco.mjtGeom.mjGEOM_HFIELD, hfieldname="bumps",
                                pos=[0, 0, low])
        top = high
    carrier = spec.worldbody.add_body(name="carrier", pos=[0, 0, top + 2 * half[2]])
    carrier.add_joint(name="press", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0, 0, 1], damping=[5.0])
    carrier.add_joint(name="turn", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 0, 1], damping=[0.0])
    carrier.add_geom(name="pad", type=mujoco.mjtGeom.mjGEOM_BOX, size=list(half), pos=[0, 0, -half[2]],
                     mass=0.1, priority=1, condim=config.hand_condim,
                     friction=[config.hand_friction, config.hand_torsional_friction, STANDARD_ROLLING_M],
                     solref=[0.004, 1.0], solimp=[0.95, 0.99, 0.001, 0.5, 2.0])
    if mode == "compliant":
        pads.make_compliant(spec, [("pad", np.array([0.0, 0.0, -1.0]))], config.pad_model())
    spec.add_actuator(name="press", target="press", trntype=mujoco.mjtTrn.mjTRN_JOINT)
    spec.add_actuator(name="turn", target="turn", trntype=mujoco.mjtTrn.mjTRN_JOINT)
    return spec.compile()


def press_pad(mode: str, force: float, heights: np.ndarray | None = None, torque_rate: float = 0.2,
              config: SceneConfig | None = None, half: tuple[float, float, float] = PAD_HALF) -> PressResult:
    """Press the pad with `force` [N], measure the normal force, then ramp a torque at
    `torque_rate` [N m/s] until the pad turns faster than `SLIP_SPEED` over `SLIP_WINDOW`. Deterministic."""
    model = pad_rig(mode, heights, config, half)
    data = mujoco.MjData(model)
    surface = model.geom("surface").id
    forces = []
    while data.time < 0.5:  # the press force ramps up over 0.3 s, then holds
        data.ctrl[0] = -force * min(1.0, data.time / 0.3)
        mujoco.mj_step(model, data)
        if data.time > 0.4:  # at rest: the mean over the last 0.1 s (a height field's contacts come and go)
            forces.append(_surface_force(model, data, surface)[0])
    normal, count = float(np.mean(forces)), _surface_force(model, data, surface)[1]
    turn = model.jnt_qposadr[model.joint("turn").id]
    start, limit = data.time, 10.0
    window = max(1, round(SLIP_WINDOW / model.opt.timestep))
    angles = [float(data.qpos[turn])]
    while data.time - start < limit:
        data.ctrl[1] = torque_rate * (data.time - start)
        mujoco.mj_step(model, data)
        angles.append(float(data.qpos[turn]))
        if len(angles) > window and abs(angles[-1] - angles[-1 - window]) > SLIP_SPEED * window * model.opt.timestep:
            break
    return PressResult(normal_force=normal, holding_torque=float(data.ctrl[1]), contacts=count)


def _surface_force(model: mujoco.MjModel, data: mujoco.MjData, surface: int) -> tuple[float, int]:
    """The force [N] the contacts with `surface` push along world z (the press axis), and their count.

    Each contact's whole force (normal and friction, in its contact frame) is turned to world z: on a
    height field's slopes the contact normals tilt and friction carries part of the press.
    """
    total, count, wrench = 0.0, 0, np.zeros(6)
    for i in range(data.ncon):
        contact = data.contact[i]
        if surface not in (contact.geom1, contact.geom2):
            continue
        mujoco.mj_contactForce(model, data, i, wrench)
        frame = contact.frame.reshape(3, 3)  # rows: normal, tangent 1, tangent 2 (world)
        push = float(frame[:, 2] @ wrench[:3])  # world z of the force between geom1 and geom2
        total += push if contact.geom1 == surface else -push
        count += 1
    return abs(total), count


def jaw_closed_on(asset: ObjectSource, config: SceneConfig | None = None, steps: int = 300) -> Scene:
    """A `parallel_jaw` scene (`config`) closed on `asset` from above, its TCP 2.5 cm over the table at the
    origin (the centre of a 5 cm cube), the base held there by impedance control for `steps` steps: the
    pads' contacts in a real grasp (their solver rows, the cost of a step)."""
    scene = build_scene("parallel_jaw", asset, config)
    pose = np.eye(4)
    pose[:3, :3], pose[:3, 3] = np.diag([1.0, -1.0, -1.0]), [0.0, 0.0, 0.025]
    scene.reset(mount=pose, synergy=1.0)
    ctrl = ImpedanceController(scene.base, default_gains(scene.base))
    ctrl.set_target(pose)
    for _ in range(steps):
        ctrl.apply()
        scene.step()
    return scene
