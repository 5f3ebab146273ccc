"""Controllers against their design: impedance step response, static stiffness, hybrid force, anti-windup."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from manigrasp.control import (
    AdaptiveStiffness,
    BaseKinematics,
    ForceGains,
    ForcePI,
    GuardedApproach,
    HybridController,
    ImpedanceController,
    ImpedanceGains,
    NativeImpedance,
    default_gains,
)
from manigrasp.errors import ConfigError
from manigrasp.geometry import quat_to_mat
from manigrasp.sim import Scene, SceneConfig, build_scene, hand_contact_wrench, read_hand_contacts

FIXED_BOX = """<mujoco><worldbody><body name="object" pos="0 0 0.02">
<geom type="box" size="0.04 0.04 0.02"/></body></worldbody></mujoco>"""


def _mount(rng: np.random.Generator, height: float = 0.4) -> np.ndarray:
    pose = np.eye(4)
    pose[:3, :3] = quat_to_mat(rng.normal(size=4))
    pose[:3, 3] = [0.0, 0.0, height]
    return pose


def _step_metrics(t: np.ndarray, y: np.ndarray, band: float = 0.02) -> tuple[float, float]:
    """Overshoot [-] and settling time [s] (last exit from the +-band around 1) of a unit step response."""
    outside = np.flatnonzero(np.abs(y - 1.0) > band)
    return float(y.max() - 1.0), float(t[outside[-1] + 1]) if len(outside) else 0.0


def _designed(omega: float, zeta: float) -> tuple[float, float]:
    t = np.arange(0.0, 3.0, 1e-5)
    wd = omega * np.sqrt(1 - zeta**2)
    y = 1 - np.exp(-zeta * omega * t) * (np.cos(wd * t) + zeta / np.sqrt(1 - zeta**2) * np.sin(wd * t))
    return _step_metrics(t, y)


@pytest.fixture(scope="module")
def free_hand() -> Scene:
    return build_scene("parallel_jaw")


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_impedance_step_matches_designed_second_order_system(free_hand: Scene, axis: int) -> None:
    scene, rng = free_hand, np.random.default_rng(axis)
    mount = _mount(rng)
    scene.reset(mount=mount)
    k, d = 250.0, 2 * 0.5 * np.sqrt(250.0 * scene.hand.mass)  # zeta = 0.5 with the hand's mass
    gains = ImpedanceGains(stiffness=[k, k, k, 20, 20, 20], damping=[d, d, d, 0.3, 0.3, 0.3])
    ctrl = ImpedanceController(scene.base, gains)
    target = mount.copy()
    target[:3, 3] += 0.05 * mount[:3, axis]  # 5 cm along a TCP axis
    ctrl.set_target(target)
    steps = 1000
    y = np.empty(steps)
    for i in range(steps):
        ctrl.apply()
        scene.step()
        y[i] = (scene.tcp_pose()[:3, 3] - mount[:3, 3]) @ mount[:3, axis] / 0.05
    over, settle = _step_metrics(scene.model.opt.timestep * np.arange(1, steps + 1), y)
    over_d, settle_d = _designed(np.sqrt(k / scene.hand.mass), d / (2 * np.sqrt(k * scene.hand.mass)))
    assert abs(over - over_d) <= 0.15 * over_d, (over, over_d)
    assert abs(settle - settle_d) <= 0.15 * settle_d, (settle, settle_d)
    assert scene.warnings() == {}


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_native_impedance_step_matches_designed_second_order_system(free_hand: Scene, axis: int) -> None:
    """The same 5 cm steps under MuJoCo's base servos (Python only samples the response each step)."""
    scene, rng = free_hand, np.random.default_rng(axis)
    mount = _mount(rng)
    scene.reset(mount=mount)
    k, d = 250.0, 2 * 0.5 * np.sqrt(250.0 * scene.hand.mass)  # zeta = 0.5 with the hand's mass
    gains = ImpedanceGains(stiffness=[k, k, k, 20, 20, 20], damping=[d, d, d, 0.3, 0.3, 0.3])
    ctrl = NativeImpedance(scene.base, gains)
    ctrl.engage()
    target = mount.copy()
    target[:3, 3] += 0.05 * mount[:3, axis]
    ctrl.set_target(target)
    steps = 1000
    y = np.empty(steps)
    for i in range(steps):
        scene.step()
        y[i] = (scene.tcp_pose()[:3, 3] - mount[:3, 3]) @ mount[:3, axis] / 0.05
    over, settle = _step_metrics(scene.model.opt.timestep * np.arange(1, steps + 1), y)
    over_d, settle_d = _designed(np.sqrt(k / scene.hand.mass), d / (2 * np.sqrt(k * scene.hand.mass)))
    assert abs(over - over_d) <= 0.15 * over_d, (over, over_d)
    assert abs(settle - settle_d) <= 0.15 * settle_d, (settle, settle_d)
    off_axis = np.delete(mount[:3, :3].T @ (scene.tcp_pose()[:3, 3] - target[:3, 3]), axis)
    assert np.all(np.abs(off_axis) < 1e-4), off_axis
    np.testing.assert_allclose(scene.data.actuator_force[scene.base.actuators], 0.0)  # the motors stay off
    assert scene.warnings() == {}


def test_native_impedance_holds_rotation_and_feeds_forward_a_load(free_hand: Scene) -> None:
    """A turned target is reached (Euler set-points), and a fed-forward 5 N pull cancels a 5 N push."""
    scene = free_hand
    mount = _mount(np.random.default_rng(11))
    scene.reset(mount=mount)
    ctrl = NativeImpedance(scene.base, default_gains(scene.base))
    ctrl.engage()
    target = mount.copy()
    target[:3, :3] = quat_to_mat([np.cos(0.1), 0.0, np.sin(0.1), 0.0]) @ mount[:3, :3]  # 11.5 deg about world y
    target[:3, 3] += [0.01, -0.02, 0.03]
    push = np.array([0.0, 0.0, -5.0])
    ctrl.set_target(target, feedforward=np.r_[-push, 0.0, 0.0, 0.0])
    scene.data.xfrc_applied[scene.root_body, :3] = push
    for _ in range(150):  # the push acts through the rotation centre (xfrc_applied acts at the body's COM)
        anchor = scene.data.xanchor[scene.base.anchor_joint]
        scene.data.xfrc_applied[scene.root_body, 3:] = np.cross(anchor - scene.data.xipos[scene.root_body], push)
        scene.step(10)
    scene.data.xfrc_applied[:] = 0.0
    np.testing.assert_allclose(scene.tcp_pose(), target, atol=2e-4)
    np.testing.assert_allclose(ctrl.joint_error(), 0.0, atol=2e-4)


def test_base_kinematics_inverts_mujoco_forward_kinematics(free_hand: Scene) -> None:
    scene, rng = free_hand, np.random.default_rng(5)
    scene.reset(mount=_mount(rng))
    kin = BaseKinematics(scene.base)
    for _ in range(5):
        q = np.r_[rng.uniform(-0.05, 0.05, 3), rng.uniform(-0.5, 0.5, 3)]
        scene.data.qpos[scene.base_qpos] = q
        mujoco.mj_forward(scene.model, scene.data)
        np.testing.assert_allclose(kin.joints(scene.tcp_pose()), q, atol=1e-12)
        twist = np.r_[rng.normal(size=3) * 0.1, rng.normal(size=3)]
        rates = kin.joint_rates(scene.tcp_pose(), twist)
        scene.data.qvel[scene.base.dofs] = rates
        jacp, jacr = np.zeros((3, scene.model.nv)), np.zeros((3, scene.model.nv))
        mujoco.mj_jacSite(scene.model, scene.data, jacp, jacr, scene.tcp_site)
        np.testing.assert_allclose(np.r_[jacp @ scene.data.qvel, jacr @ scene.data.qvel], twist, atol=1e-4)
        scene.data.qvel[:] = 0.0


def test_static_stiffness_is_per_axis_in_tcp_frame(free_hand: Scene) -> None:
    scene = free_hand
    mount = _mount(np.random.default_rng(7))
    scene.reset(mount=mount)
    k = np.array([300.0, 600.0, 1200.0])
    gains = ImpedanceGains(stiffness=[*k, 30, 30, 30], damping=[40, 40, 40, 0.5, 0.5, 0.5])
    ctrl = ImpedanceController(scene.base, gains)
    ctrl.set_target(mount)
    push = mount[:3, :3] @ np.array([3.0, 3.0, 3.0])  # 3 N along each TCP axis, through the COM
    for _ in range(1500):
        ctrl.apply()
        scene.data.xfrc_applied[scene.root_body, :3] = push
        scene.data.xfrc_applied[scene.root_body, 3:] = np.cross(scene.data.xipos[scene.root_body] -
                                                                scene.data.xanchor[scene.base.anchor_joint], push)
        scene.step()
    scene.data.xfrc_applied[:] = 0.0
    deflection = mount[:3, :3].T @ (scene.tcp_pose()[:3, 3] - mount[:3, 3])
    np.testing.assert_allclose(deflection, 3.0 / k, rtol=0.03)


def test_adaptive_stiffness_raises_stiffness_with_error(free_hand: Scene) -> None:
    adaptive = AdaptiveStiffness(error_scale=0.01, max_factor=3.0)
    assert adaptive.factors(0.0, 0.0) == (1.0, 1.0)
    assert adaptive.factors(0.01, 0.0)[0] == pytest.approx(2.0)
    assert adaptive.factors(1.0, 10.0) == (3.0, 3.0)
    scene = free_hand
    mount = _mount(np.random.default_rng(3))
    sag = {}
    for name, adapt in (("fixed", None), ("adaptive", adaptive)):
        scene.reset(mount=mount)
        ctrl = ImpedanceController(scene.base, default_gains(scene.base, omega=15.0), adapt)
        ctrl.set_target(mount)
        for _ in range(1500):
            ctrl.apply()
            scene.data.xfrc_applied[scene.root_body, :3] = [0.0, 0.0, -5.0]
            scene.step()
        scene.data.xfrc_applied[:] = 0.0
        sag[name] = mount[2, 3] - scene.tcp_pose()[2, 3]
    assert sag["adaptive"] < 0.8 * sag["fixed"]


def test_controller_compensates_gravity_when_mujoco_does_not() -> None:
    scene = build_scene("parallel_jaw", config=SceneConfig(hand_gravcomp=False))
    mount = _mount(np.random.default_rng(1))
    scene.reset(mount=mount)
    ctrl = ImpedanceController(scene.base, default_gains(scene.base))
    ctrl.set_target(mount)
    for _ in range(1000):
        ctrl.apply()
        scene.step()
    assert np.linalg.norm(scene.tcp_pose()[:3, 3] - mount[:3, 3]) < 1e-4


def test_force_pi_integrates_over_time_and_does_not_wind_up() -> None:
    coarse, fine = ForcePI(0.0, 2.0, 100.0), ForcePI(0.0, 2.0, 100.0)
    for _ in range(10):
        coarse.update(1.0, 0.01)
    for _ in range(100):
        fine.update(1.0, 0.001)
    np.testing.assert_allclose(coarse.integral, fine.integral)  # same 0.1 s, any rate
    clamped = ForcePI(0.0, 2.0, 0.5)
    for _ in range(1000):
        out = clamped.update(1.0, 0.01)
    assert out[0] == pytest.approx(0.5)  # |ki z| <= limit
    blocked = ForcePI(0.0, 2.0, 100.0)
    for _ in range(100):
        blocked.update(1.0, 0.01, push_up_blocked=True)
    assert blocked.integral[0] == 0.0
    assert blocked.update(-1.0, 0.01, push_up_blocked=True)[0] < 0  # unwinding is allowed
    with pytest.raises(ConfigError):
        ForcePI(-1.0, 1.0, 1.0)


def _press_scene() -> tuple[Scene, np.ndarray]:
    scene = build_scene("parallel_jaw", mujoco.MjSpec.from_string(FIXED_BOX))
    pose = np.eye(4)
    pose[:3, :3] = np.diag([1.0, -1.0, -1.0])  # approach straight down
    pose[:3, 3] = [0.0, 0.0, 0.04 + 0.015 + 0.005]  # pad tips 5 mm above the box top
    return scene, pose


def test_hybrid_presses_fixed_box_with_target_force_and_holds_position() -> None:
    scene, pose = _press_scene()
    scene.reset(mount=pose, synergy=1.0)
    target = 20.0
    ctrl = HybridController(scene.base, default_gains(scene.base), ForceGains(), np.array([1, 1, 0, 1, 1, 1]))
    ctrl.set_target(pose, np.array([0.0, 0.0, target, 0.0, 0.0, 0.0]))
    dt = scene.model.opt.timestep
    for _ in range(1000):
        tcp = scene.tcp_pose()
        measured = np.kron(np.eye(2), tcp[:3, :3]).T @ hand_contact_wrench(scene, tcp[:3, 3], "object")
        ctrl.apply(measured, dt)
        scene.step()
    force = read_hand_contacts(scene).force.sum(axis=0) @ pose[:3, 2]  # the hand pushes along approach
    assert abs(force - target) <= 0.05 * target, force
    xy = scene.tcp_pose()[:2, 3] - pose[:2, 3]
    assert np.all(np.abs(xy) < 1e-3), xy
    assert scene.warnings() == {}


def test_guarded_approach_stops_at_contact_threshold() -> None:
    scene, above = _press_scene()
    start = above.copy()
    start[2, 3] += 0.05
    goal = above.copy()
    goal[2, 3] -= 0.03  # 2.5 cm inside the box: the guard must stop the hand
    scene.reset(mount=start, synergy=1.0)
    approach = GuardedApproach(scene.base, default_gains(scene.base), ForceGains(), threshold=5.0, speed=0.05)
    approach.begin(start, goal)
    dt = scene.model.opt.timestep
    for _ in range(1500):
        tcp = scene.tcp_pose()
        measured = np.kron(np.eye(2), tcp[:3, :3]).T @ hand_contact_wrench(scene, tcp[:3, 3], "object")
        approach.apply(measured, dt)
        scene.step()
    assert approach.tripped and not approach.reached
    pushed = read_hand_contacts(scene).force.sum(axis=0) @ above[:3, 2]
    assert abs(pushed - 5.0) <= 0.1 * 5.0, pushed
    assert scene.tcp_pose()[2, 3] > goal[2, 3] + 0.02  # stopped on the surface, not inside
