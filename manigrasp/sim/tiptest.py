"""A fingertip pressed and pulled, closed loop in MuJoCo: what a dexterous hand's fingertip holds.

One fingertip geom of a compiled scene (its shape, friction, contact priority, condim and solver parameters as
the scene has them) is fixed at the world origin, posed as in its own body's frame; gravity is off. A box on
three slide joints (it translates, never turns) touches it from +x and is pressed onto it with a constant force
F, then pulled along the contact plane (world z) by a force growing at a slow, constant rate until it slides.
`press_fingertip` measures the normal force the fingertip returns, the contact's penetration and the pull at
which the box slid: mu F for a fingertip of sliding friction mu (the hand geoms have contact priority, so the
fingertip's friction is the contact's).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from manigrasp.errors import SimulationError

BOX_HALF = (0.01, 0.03, 0.03)  # [m] the pressed box (thin along the press)
BOX_MASS = 0.1  # [kg]
BOX_FRICTION = (0.5, 0.005, 0.0001)  # an object's (sliding, torsional, rolling) friction
SLIP_SPEED = 0.01  # [m/s] the box counts as sliding once it moves faster than this
SETTLE_S = 0.5  # [s] pressed before the pull starts


@dataclass(frozen=True)
class TipPress:
    """What a pressed fingertip measured.

    Attributes:
        friction: the fingertip's sliding friction in the scene [-].
        normal_force: total normal force on the box at rest under the press [N].
        penetration: deepest contact penetration at rest [m].
        contacts: number of fingertip-box contacts at rest.
        slip_force: pull along the contact plane at which the box slid [N] (inf: it held the whole ramp).
    """

    friction: float
    normal_force: float
    penetration: float
    contacts: int
    slip_force: float


def fingertip_rig(scene: mujoco.MjModel, geom: int) -> mujoco.MjModel:
    """The rig's model for geom `geom` (a sphere, capsule or mesh fingertip) of the compiled `scene`."""
    kind = int(scene.geom_type[geom])
    spec = mujoco.MjSpec()
    spec.option.timestep = float(scene.opt.timestep)
    spec.option.cone = int(scene.opt.cone)
    spec.option.impratio = float(scene.opt.impratio)
    spec.option.integrator = int(scene.opt.integrator)
    spec.option.gravity = [0.0, 0.0, 0.0]
    tip = spec.worldbody.add_geom(name="tip", type=kind, size=scene.geom_size[geom], pos=scene.geom_pos[geom],
                                  quat=scene.geom_quat[geom], friction=scene.geom_friction[geom],
                                  priority=int(scene.geom_priority[geom]), condim=int(scene.geom_condim[geom]),
                                  solref=scene.geom_solref[geom], solimp=scene.geom_solimp[geom],
                                  margin=float(scene.geom_margin[geom]), gap=float(scene.geom_gap[geom]))
    rot = np.zeros(9)
    mujoco.mju_quat2Mat(rot, scene.geom_quat[geom])
    if kind == mujoco.mjtGeom.mjGEOM_MESH:
        mesh = int(scene.geom_dataid[geom])
        verts = scene.mesh_vert[scene.mesh_vertadr[mesh]:scene.mesh_vertadr[mesh] + scene.mesh_vertnum[mesh]]
        spec.add_mesh(name="tip", uservert=verts.ravel())
        tip.meshname = "tip"
        reach = float(np.max(verts @ rot.reshape(3, 3).T[:, 0]))
    elif kind in (mujoco.mjtGeom.mjGEOM_SPHERE, mujoco.mjtGeom.mjGEOM_CAPSULE):
        capsule = kind == mujoco.mjtGeom.mjGEOM_CAPSULE
        reach = float(scene.geom_size[geom][0] + (abs(rot[2]) * scene.geom_size[geom][1] if capsule else 0.0))
    else:
        raise SimulationError(f"fingertip rig: geom type {kind} is not a sphere, capsule or mesh")
    box = spec.worldbody.add_body(name="box", pos=[scene.geom_pos[geom][0] + reach + BOX_HALF[0], 0.0, 0.0])
    for axis in np.eye(3):
        box.add_joint(type=mujoco.mjtJoint.mjJNT_SLIDE, axis=axis)
    box.add_geom(name="box", type=mujoco.mjtGeom.mjGEOM_BOX, size=BOX_HALF, mass=BOX_MASS, friction=BOX_FRICTION,
                 condim=4)
    return spec.compile()


def press_fingertip(scene: mujoco.MjModel, geom: int, force: float, pull_rate: float = 2.0) -> TipPress:
    """Press a box with `force` [N] on fingertip `geom` of `scene` for `SETTLE_S`, then pull it along the
    contact plane at `pull_rate` [N/s] (up to 2 x force) until it slides (`fingertip_rig`)."""
    model = fingertip_rig(scene, geom)
    data = mujoco.MjData(model)
    box = model.body("box").id
    data.xfrc_applied[box, 0] = -force
    mujoco.mj_step(model, data, nstep=round(SETTLE_S / model.opt.timestep))
    normal, wrench = 0.0, np.zeros(6)
    for i in range(data.ncon):
        mujoco.mj_contactForce(model, data, i, wrench)
        normal += float(wrench[0])
    penetration = float(-np.min(data.contact.dist[:data.ncon])) if data.ncon else 0.0
    contacts, start, slip = int(data.ncon), data.time, np.inf
    while data.time - start < 2.0 * force / pull_rate:
        data.xfrc_applied[box, 2] = pull_rate * (data.time - start)
        mujoco.mj_step(model, data)
        if abs(data.qvel[2]) > SLIP_SPEED:
            slip = float(data.xfrc_applied[box, 2])
            break
    return TipPress(friction=float(scene.geom_friction[geom, 0]), normal_force=normal, penetration=penetration,
                    contacts=contacts, slip_force=slip)
