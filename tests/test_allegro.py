"""The Allegro hand (the 'allegro' extra): fixes at load, frames, the missing-package error, grip at its limits.

The registry's smoke and physics tests (open, close, regulated grip, hand-placed can lift) run on
allegro_right and allegro_left through tests/test_hands_physics.py, which is parameterised over every hand.
"""

from __future__ import annotations

import importlib.metadata
import json
import xml.etree.ElementTree as ET

import mujoco
import numpy as np
import pytest
import trimesh

from manigrasp import hands
from manigrasp.cli import main
from manigrasp.control import GripController, ImpedanceController, default_gains
from manigrasp.errors import HandError
from manigrasp.hands import allegro
from manigrasp.hands.placement import side_power_grasp
from manigrasp.objects import build_object
from manigrasp.sim import build_scene, grip_force, read_hand_contacts

pytest.importorskip("cmeel", reason="the Allegro hand needs the 'allegro' extra (example-robot-data)")


@pytest.fixture(scope="module")
def right() -> hands.Hand:
    return hands.load("allegro_right")


def _urdf_limits(name: str) -> dict[str, tuple[float, float]]:
    root = ET.parse(allegro.description_dir() / "urdf" / f"{name}_hand.urdf").getroot()
    return {j.get("name"): (float(j.find("limit").get("lower")), float(j.find("limit").get("upper")))
            for j in root.iter("joint") if j.get("type") == "revolute"}


def test_missing_package_names_the_extra(monkeypatch: pytest.MonkeyPatch) -> None:
    def missing(name: str) -> None:
        raise importlib.metadata.PackageNotFoundError(name)

    monkeypatch.setattr(allegro.importlib.metadata, "distribution", missing)
    with pytest.raises(HandError, match=r"'allegro' extra.*make setup EXTRAS=dev,allegro.*example-robot-data==6\.0\.0"):
        allegro.make("allegro_right")


@pytest.mark.parametrize("name", ["allegro_right", "allegro_left"])
def test_joints_keep_the_urdf_limits_and_get_realistic_servos(name: str) -> None:
    model = hands.load(name).build_spec().compile()
    limits = _urdf_limits(name)
    assert model.njnt == model.nu == len(limits) == 16
    for joint, (low, high) in limits.items():
        j = model.joint(joint).id
        np.testing.assert_allclose(model.jnt_range[j], [low, high])
        assert model.dof_frictionloss[model.jnt_dofadr[j]] == 0.0  # the URDF's 5-12 N m is gone
        assert model.dof_damping[model.jnt_dofadr[j]] == pytest.approx(allegro.DAMPING)
        act = model.actuator(joint).id
        np.testing.assert_allclose(model.actuator_forcerange[act], [-allegro.TORQUE, allegro.TORQUE])
        assert model.actuator_ctrlrange[act, 0] == pytest.approx(low)
    # Visual meshes do not collide; every colliding geom is a box or a sphere (the URDF's collision model).
    colliding = (model.geom_contype | model.geom_conaffinity) > 0
    assert set(model.geom_type[colliding].tolist()) == {mujoco.mjtGeom.mjGEOM_BOX, mujoco.mjtGeom.mjGEOM_SPHERE}
    assert np.all(model.geom_type[~colliding] == mujoco.mjtGeom.mjGEOM_MESH)
    assert np.sum(model.geom_type[colliding] == mujoco.mjtGeom.mjGEOM_SPHERE) == 4  # one per fingertip


def test_open_preshape_is_qpos0_and_the_tcp_frame_follows_the_convention(right: hands.Hand) -> None:
    model = right.build_spec().compile()
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    for act in range(model.nu):  # qpos0 is the open command of every servo (thumb opposed, fingers straight)
        assert data.qpos[model.jnt_qposadr[model.actuator_trnid[act, 0]]] == pytest.approx(right.open_ctrl[act])
    tcp = model.site(right.tcp_site).id
    frame = data.site_xmat[tcp].reshape(3, 3)
    np.testing.assert_allclose(frame[:, 2], [1, 0, 0], atol=1e-9)  # approach: the palm normal
    np.testing.assert_allclose(frame[:, 1], [0, 0, 1], atol=1e-9)  # closing: thumb toward the fingertips
    # The opposed thumb's tip lies in front of the palm (along approach) and below the TCP (along -closing).
    thumb = data.xpos[model.body(allegro.TIPS["thumb"]).id] - data.site_xpos[tcp]
    assert thumb @ frame[:, 2] > right.max_width / 2 and thumb @ frame[:, 1] < 0
    # Closing bends every finger toward the palm side (+approach).
    before = {f: data.xpos[model.body(allegro.TIPS[f]).id] @ frame[:, 2] for f in allegro.FINGERS}
    for act in range(model.nu):
        data.qpos[model.jnt_qposadr[model.actuator_trnid[act, 0]]] = min(
            right.synergy_ctrl(0.3)[act], model.jnt_range[model.actuator_trnid[act, 0], 1])
    mujoco.mj_kinematics(model, data)
    for finger in allegro.FINGERS:
        assert data.xpos[model.body(allegro.TIPS[finger]).id] @ frame[:, 2] > before[finger] + 0.02


def test_left_hand_mirrors_the_right(right: hands.Hand) -> None:
    left = hands.load("allegro_left")
    tcp_r, tcp_l = (h.build_spec().site(h.tcp_site).pos for h in (right, left))
    np.testing.assert_allclose(tcp_l, tcp_r * np.array([1, -1, 1]), atol=1e-4)
    assert left.max_width == pytest.approx(right.max_width, rel=1e-6)
    assert left.max_grip_force == pytest.approx(right.max_grip_force, rel=1e-6)


def _collision_extent(model: mujoco.MjModel, body: str, axis: int) -> tuple[float, float]:
    """(lowest, highest) coordinate along `axis` of the collision geoms of `body`, in its own frame [m]."""
    b = model.body(body).id
    lows, highs = [], []
    for g in np.flatnonzero((model.geom_bodyid == b) & ((model.geom_contype > 0) | (model.geom_conaffinity > 0))):
        half = model.geom_size[g, :3] if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX else model.geom_size[g, :1]
        lows.append(model.geom_pos[g, axis] - half[min(axis, len(half) - 1)])
        highs.append(model.geom_pos[g, axis] + half[min(axis, len(half) - 1)])
    return min(lows), max(highs)


@pytest.mark.parametrize(("distal", "tip", "mesh_end"), [("link_3.0", "link_3.0_tip", 0.0157),
                                                          ("link_15.0", "link_15.0_tip", 0.0313)])
def test_distal_collision_box_ends_where_the_link_mesh_does(right: hands.Hand, distal: str, tip: str,
                                                           mesh_end: float) -> None:
    """The distal link's collision box ends where its visual mesh does (15.7 / 31.3 mm, as read from the STL), not at
    the fingertip sphere's centre; the sphere (the 24 mm ball of link_*_tip.STL) is then the finger's outermost
    collision geometry, and nothing wider than it reaches past the box's end."""
    model = right.build_spec().compile()
    folder = allegro.description_dir() / "meshes"
    assert trimesh.load(folder / f"{distal}.STL").bounds[1, 2] == pytest.approx(mesh_end, abs=2e-4)
    assert _collision_extent(model, distal, 2) == pytest.approx((0.0, mesh_end), abs=2e-4)
    tip_offset = model.body(tip).pos[2]
    assert tip_offset - 0.012 < mesh_end < tip_offset  # the ball starts where the box ends
    untrimmed = allegro.make_from(allegro.AllegroModel("allegro_right", "allegro_right_hand.urdf",
                                                       trim_distal=False)).build_spec().compile()
    assert _collision_extent(untrimmed, distal, 2)[1] == pytest.approx(tip_offset, abs=2e-4)  # the URDF's box


@pytest.fixture(scope="module")
def wide_can_scene(right: hands.Hand, tmp_path_factory: pytest.TempPathFactory):
    can = build_object(trimesh.creation.cylinder(0.038, 0.12, sections=48), name="wide_can", mass=0.35,
                       cache_root=tmp_path_factory.mktemp("objects")).asset
    return build_scene(right, can)


def _side_grasp(scene) -> np.ndarray:
    return side_power_grasp(scene.hand, [0.0, 0.0, scene.object_rest_height])


def _run(scene, pose: np.ndarray, steps: int, grip: GripController | None = None) -> None:
    ctrl = ImpedanceController(scene.base, default_gains(scene.base))
    ctrl.set_target(pose)
    dt = scene.model.opt.timestep
    for _ in range(steps):
        ctrl.apply()
        if grip is not None:
            scene.set_synergy(grip.update(grip_force(read_hand_contacts(scene)), dt, scene.hand_synergy(),
                                          scene.closing_reach()))
        scene.step()


def test_regulated_grip_reaches_the_declared_maximum_with_all_four_fingers(wide_can_scene) -> None:
    scene = wide_can_scene
    pose = _side_grasp(scene)
    scene.reset(mount=pose)
    grip = GripController(scene.hand.max_grip_force, scene.hand.max_grip_force, close_speed=2.0)
    _run(scene, pose, 1500, grip)
    contacts = read_hand_contacts(scene)
    assert abs(grip_force(contacts) - scene.hand.max_grip_force) <= 0.05 * scene.hand.max_grip_force
    assert contacts.fingers_touching == (0, 1, 2, 3)


def test_full_close_pushes_every_blocked_bending_joint_at_its_torque_limit(wide_can_scene) -> None:
    scene = wide_can_scene
    pose = _side_grasp(scene)
    scene.reset(mount=pose, synergy=0.0)
    scene.set_synergy(1.0)
    _run(scene, pose, 1500)
    model = scene.model
    for chain in allegro.BENDING.values():
        for joint in chain:
            act = model.actuator(f"hand/{joint}").id
            assert scene.data.actuator_force[act] == pytest.approx(allegro.TORQUE, abs=0.01), joint
    assert scene.warnings() == {}


def test_cli_lists_both_allegro_hands(capsys: pytest.CaptureFixture[str]) -> None:
    main(["hands", "list", "--json"])
    records = {r["name"]: r for r in json.loads(capsys.readouterr().out)}
    for name in ("allegro_right", "allegro_left"):
        assert records[name]["actuated_dof"] == 16 and records[name]["kind"] == "dexterous"
