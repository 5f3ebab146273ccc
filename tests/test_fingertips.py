"""Dexterous fingertips with `pads: compliant`: the rubber-covered fingertip geoms touch with the pad rubber's
friction (`SceneConfig.pad_friction`), every other hand geom with the hand's; `pads: rigid` is unchanged.

Closed loop: one fingertip geom, copied from the compiled scene (shape, friction, priority, condim, solver
parameters), is fixed in a gravity-free rig; a box on three slide joints is pressed onto it with a force F and
then pulled along the contact plane by a slowly growing force. The box holds until that force reaches mu F,
mu the fingertip's sliding friction in the scene: 0.5 with rigid pads, the rubber's 1.0 with compliant ones.
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from manigrasp import hands
from manigrasp.errors import SimulationError
from manigrasp.sim import build_scene
from manigrasp.sim.compose import HAND_PREFIX
from manigrasp.sim.config import SceneConfig

DEXTEROUS = [n for n in ("inspire_right", "inspire_left", "fourier_right", "fourier_left", "allegro_right",
                         "allegro_left") if n in hands.names()]
PRESS = 5.0  # [N], the force pressing the box onto the fingertip
PULL_RATE = 2.0  # [N/s], growth of the force along the contact plane
SLIP_SPEED = 0.01  # [m/s], the box counts as sliding once it moves faster than this
BOX_HALF = (0.01, 0.03, 0.03)  # [m]


def _hand_model(name: str, pads: str) -> mujoco.MjModel:
    return build_scene(hands.load(name), None, SceneConfig(pads=pads)).model


def _geom(model: mujoco.MjModel, name: str) -> int:
    return mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, HAND_PREFIX + name)


@pytest.mark.parametrize("name", DEXTEROUS)
def test_compliant_pads_give_the_fingertips_the_rubber_friction_and_nothing_else(name: str) -> None:
    hand = hands.load(name)
    assert len(hand.fingertip_geoms) == (5 if not name.startswith("allegro") else 4)
    config = SceneConfig(pads="compliant")
    model = _hand_model(name, "compliant")
    tips = {_geom(model, g) for g in hand.fingertip_geoms}
    assert -1 not in tips
    hand_geoms = [g for g in range(model.ngeom) if model.geom_priority[g] >= 1 and model.geom_contype[g]]
    for g in hand_geoms:
        want = config.pad_friction if g in tips else config.hand_friction
        assert model.geom_friction[g, 0] == want, mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g)
        assert model.geom_friction[g, 1] == config.hand_torsional_friction


@pytest.mark.parametrize("name", DEXTEROUS)
def test_rigid_pads_leave_the_dexterous_hand_as_modelled(name: str) -> None:
    """Bit for bit: declaring fingertips changes nothing under `pads: rigid` (the model of the same hand
    without fingertip geoms is identical in every numeric array)."""
    hand = hands.load(name)
    with_tips = build_scene(hand, None, SceneConfig(pads="rigid")).model
    without = build_scene(dataclasses.replace(hand, fingertip_geoms=()), None, SceneConfig(pads="rigid")).model
    arrays = [a for a in dir(with_tips) if not a.startswith("_") and isinstance(getattr(with_tips, a), np.ndarray)]
    assert len(arrays) > 100
    for attr in arrays:
        np.testing.assert_array_equal(getattr(with_tips, attr), getattr(without, attr), err_msg=attr)
    assert set(with_tips.geom_friction[with_tips.geom_priority >= 1, 0]) == {SceneConfig().hand_friction}


def test_a_fingertip_that_is_not_a_colliding_geom_is_refused() -> None:
    hand = dataclasses.replace(hands.load("inspire_right"), fingertip_geoms=("no_such_geom",))
    with pytest.raises(SimulationError, match="fingertip geom 'no_such_geom'"):
        build_scene(hand, None, SceneConfig(pads="compliant"))
    build_scene(hand, None, SceneConfig(pads="rigid"))  # rigid pads never look at them


def _rig(scene: mujoco.MjModel, geom: int) -> tuple[mujoco.MjModel, float]:
    """The fingertip `geom` of a compiled scene fixed at the world origin (as in its body frame) and a box on
    slide joints touching it from +x; returns the rig and the fingertip's sliding friction."""
    spec = mujoco.MjSpec()
    spec.option.timestep = float(scene.opt.timestep)
    spec.option.cone = int(scene.opt.cone)
    spec.option.impratio = float(scene.opt.impratio)
    spec.option.integrator = int(scene.opt.integrator)
    spec.option.gravity = [0.0, 0.0, 0.0]
    kind = int(scene.geom_type[geom])
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
        reach = float(np.max(scene.geom_pos[geom][0] + verts @ rot.reshape(3, 3).T[:, 0]))
    else:
        reach = float(scene.geom_pos[geom][0] + scene.geom_size[geom][0])  # sphere
    box = spec.worldbody.add_body(name="box", pos=[reach + BOX_HALF[0], 0.0, 0.0])
    for axis in np.eye(3):
        box.add_joint(type=mujoco.mjtJoint.mjJNT_SLIDE, axis=axis)
    box.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=BOX_HALF, mass=0.1, friction=[0.5, 0.005, 0.0001], condim=4)
    return spec.compile(), float(scene.geom_friction[geom, 0])


def _pinch(model: mujoco.MjModel) -> tuple[float, float]:
    """Press the box on the fingertip with `PRESS`, then pull it along z: (normal force at rest [N],
    pulling force at which the box slid [N])."""
    data = mujoco.MjData(model)
    box = model.body("box").id
    data.xfrc_applied[box, 0] = -PRESS
    mujoco.mj_step(model, data, nstep=int(0.5 / model.opt.timestep))
    normal = 0.0
    force = np.zeros(6)
    for i in range(data.ncon):
        mujoco.mj_contactForce(model, data, i, force)
        normal += force[0]
    start = data.time
    while data.time - start < 2.0 * PRESS / PULL_RATE:
        data.xfrc_applied[box, 2] = PULL_RATE * (data.time - start)
        mujoco.mj_step(model, data)
        if abs(data.qvel[2]) > SLIP_SPEED:
            return normal, float(data.xfrc_applied[box, 2])
    return normal, np.inf


@pytest.mark.parametrize("pads", ["rigid", "compliant"])
@pytest.mark.parametrize("name", [n for n in DEXTEROUS if n.endswith("right")])
def test_a_pressed_fingertip_holds_its_friction_times_the_press(name: str, pads: str) -> None:
    scene = _hand_model(name, pads)
    geom = _geom(scene, hands.load(name).fingertip_geoms[1])  # the index fingertip
    rig, mu = _rig(scene, geom)
    assert mu == (1.0 if pads == "compliant" else 0.5)
    normal, slid_at = _pinch(rig)
    assert normal == pytest.approx(PRESS, rel=0.02)
    assert slid_at == pytest.approx(mu * PRESS, rel=0.05)
