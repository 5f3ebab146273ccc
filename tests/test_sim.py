"""Scene composition, reset/mount without recompiling, and contact read-out against statics."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from manigrasp.control import ImpedanceController, default_gains
from manigrasp.errors import ConfigError, SimulationError
from manigrasp.geometry import quat_to_mat
from manigrasp.sim import (
    SceneConfig,
    build_scene,
    contact_forces,
    current_grip_force,
    grip_force,
    read_hand_contacts,
    to_contacts,
)
from manigrasp.sim.compose import BASE_JOINTS

TOP_GRASP = np.diag([1.0, -1.0, -1.0])


@pytest.fixture(scope="module")
def box_scene(box_scene):
    """The shared cube scene's `Scene` (conftest `box_scene`; the cube is `box_asset`)."""
    return box_scene.scene


def test_names_are_prefixed_per_part(box_scene) -> None:
    m = box_scene.model
    for name in ("hand/palm", "hand/finger1", "object/object"):
        assert mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, name) >= 0
    assert mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "table/top") >= 0
    joints = [m.joint(j).name for j in range(m.body_jntadr[box_scene.root_body],
                                               m.body_jntadr[box_scene.root_body] + m.body_jntnum[box_scene.root_body])]
    assert tuple(joints) == BASE_JOINTS
    assert not m.jnt_limited[[m.joint(j).id for j in BASE_JOINTS]].any()  # no leak from the hand's childclass


def test_reset_puts_tcp_on_mount_without_recompiling(box_scene) -> None:
    model = box_scene.model
    rng = np.random.default_rng(0)
    for _ in range(5):
        mount = np.eye(4)
        mount[:3, :3] = quat_to_mat(rng.normal(size=4))
        mount[:3, 3] = rng.uniform(-0.2, 0.2, 3) + [0, 0, 0.4]
        box_scene.reset(mount=mount)
        assert box_scene.model is model
        np.testing.assert_allclose(box_scene.tcp_pose(), mount, atol=1e-9)
        np.testing.assert_allclose(box_scene.data.qpos[box_scene.base_qpos], 0.0)
    with pytest.raises(ValueError, match="proper rotation"):
        box_scene.set_mount(np.diag([1.0, 1.0, -1.0, 1.0]))


def test_object_rests_on_table(box_scene) -> None:
    far = np.eye(4)
    far[:3, 3] = [0.0, 0.0, 0.5]
    box_scene.reset(mount=far)
    assert box_scene.object_rest_height == pytest.approx(0.025, abs=1e-6)
    start = box_scene.object_pose()
    ctrl = ImpedanceController(box_scene.base, default_gains(box_scene.base))
    ctrl.set_target(far)
    for _ in range(250):
        ctrl.apply()
        box_scene.step()
    assert np.linalg.norm(box_scene.object_pose()[:3, 3] - start[:3, 3]) < 1e-3
    assert box_scene.warnings() == {} and box_scene.is_finite()


def _grasp_and_lift(scene) -> None:
    pose = np.eye(4)
    pose[:3, :3], pose[:3, 3] = TOP_GRASP, [0.0, 0.0, 0.025]
    scene.reset(mount=pose, synergy=1.0)
    ctrl = ImpedanceController(scene.base, default_gains(scene.base))
    ctrl.set_target(pose)
    for i in range(900):
        if i >= 300:
            pose[2, 3] = 0.025 + min(0.05, 0.05 * (i - 300) / 200)
            ctrl.set_target(pose)
        ctrl.apply()
        scene.step()


def test_contact_forces_hold_the_object_weight(box_scene) -> None:
    _grasp_and_lift(box_scene)
    c = read_hand_contacts(box_scene)
    weight = box_scene.object_mass() * 9.81
    total = c.force.sum(axis=0)
    assert total[2] == pytest.approx(weight, rel=0.02)  # the hand carries the object: sign and size
    assert np.all(np.abs(total[:2]) < 0.02 * weight)
    assert c.fingers_touching == (0, 1)
    assert grip_force(c) == pytest.approx(box_scene.hand.max_grip_force, rel=0.02)
    # Normals point from the hand into the object, forces lie in their friction cones.
    centre = box_scene.object_pose()[:3, 3]
    assert np.all(np.einsum("ij,ij->i", c.normal, centre - c.position) > 0)
    # The default compliant pads touch with their rubber's friction (pad_friction), not the hand's 0.5.
    assert np.all(c.in_cone) and np.all(c.friction == pytest.approx(box_scene.config.pad_friction))
    assert np.all(c.normal_force > 0)


def test_to_contacts_gives_soft_finger_records_for_rigid_pads(box_asset) -> None:
    scene = build_scene("parallel_jaw", box_asset, SceneConfig(pads="rigid"))
    _grasp_and_lift(scene)
    records = to_contacts(read_hand_contacts(scene))
    assert len(records) >= 2
    assert {r.kind.value for r in records} == {"soft_finger"}
    assert all(r.mu == pytest.approx(0.5) and r.gamma > 0 for r in records)


def test_compliant_pads_touch_with_a_patch_of_point_contacts(box_asset) -> None:
    """Every element of both pads touches the flat box face, each a soft finger with the torsional
    friction of its own cell (`hands.pads`: the patch's torsion shared among its elements)."""
    scene = build_scene("parallel_jaw", box_asset, SceneConfig(pads="compliant"))
    _grasp_and_lift(scene)
    contacts = read_hand_contacts(scene)
    records = to_contacts(contacts)
    elements = [i for i in range(scene.model.ngeom) if "padel_" in scene.model.geom(i).name]
    assert len(elements) >= 2 * 4 and len(records) == len(elements)
    assert {r.kind.value for r in records} == {"soft_finger"}
    assert all(r.gamma == pytest.approx(records[0].gamma) and r.gamma > 0 for r in records)
    assert grip_force(contacts) == pytest.approx(scene.hand.max_grip_force, rel=0.02)


def test_fixed_object_and_bad_object_mjcf(tmp_path) -> None:
    fixed = mujoco.MjSpec.from_string('<mujoco><worldbody><body name="object" pos="0 0 0.02">'
                                      '<geom type="box" size="0.02 0.02 0.02"/></body></worldbody></mujoco>')
    scene = build_scene("parallel_jaw", fixed)
    assert scene.model.body_jntnum[scene.object_body] == 0
    bad = tmp_path / "bad.xml"
    bad.write_text('<mujoco><worldbody><body name="thing"><geom size="0.01"/></body></worldbody></mujoco>')
    with pytest.raises(SimulationError, match="no body named 'object'.*thing"):
        build_scene("parallel_jaw", bad)


def test_config_is_validated() -> None:
    with pytest.raises(ConfigError, match="implicitfast"):
        SceneConfig(integrator="implicitfst")
    with pytest.raises(ConfigError, match="timestep"):
        SceneConfig(timestep=0.0)
    model = build_scene("parallel_jaw", config=SceneConfig(timestep=0.001, impratio=5.0)).model
    assert model.opt.timestep == 0.001 and model.opt.impratio == 5.0
    assert model.opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC
    assert model.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST


@pytest.mark.parametrize("cone", ["elliptic", "pyramidal"])
@pytest.mark.parametrize("condim", [1, 3, 4, 6])
def test_vectorised_contact_forces_equal_mj_contact_force(box_asset, cone: str, condim: int) -> None:
    """`contact_forces` (all contacts at once from efc_force) against MuJoCo's per-contact function."""
    asset_scene = build_scene("parallel_jaw", box_asset, SceneConfig(cone=cone, hand_condim=condim))
    pose = np.eye(4)
    pose[:3, :3], pose[:3, 3] = TOP_GRASP, [0.005, 0.0, 0.025]  # off-centre: friction carries a torque
    asset_scene.reset(mount=pose, synergy=1.0)
    ctrl = ImpedanceController(asset_scene.base, default_gains(asset_scene.base))
    ctrl.set_target(pose)
    for _ in range(300):
        ctrl.apply()
        asset_scene.step()
    model, data = asset_scene.model, asset_scene.data
    assert data.ncon >= 4
    expected = np.zeros((data.ncon, 6))
    for i in range(data.ncon):
        mujoco.mj_contactForce(model, data, i, expected[i])
    np.testing.assert_allclose(contact_forces(model, data, np.arange(data.ncon)), expected, atol=1e-9)
    assert current_grip_force(asset_scene) == pytest.approx(grip_force(read_hand_contacts(asset_scene)), abs=1e-9)
    assert current_grip_force(asset_scene) == pytest.approx(asset_scene.hand.max_grip_force, rel=0.02)
