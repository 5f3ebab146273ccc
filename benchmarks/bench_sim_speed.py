"""Simulation speed per hand holding an object: controller off vs on, side by side in one run.

    .venv/bin/python benchmarks/bench_sim_speed.py [--steps 2000] [--hands parallel_jaw panda ...]

For each hand: build the scene (box for parallel jaws, can for dexterous
hands), grasp and lift the object, then time `--steps` steps four ways from
the same state: controller off (the base held by MuJoCo's own joint
springs and dampers with the same K and D: plain `mj_step`, no Python per
step); the native impedance the protocols use (`NativeImpedance`: MuJoCo's
base servos, the set-point rewritten every `--control-period` and the steps
in between in one `mj_step(..., nstep=k)` call); the Python Cartesian
impedance controller (`ImpedanceController.apply()` every step); and that
plus the grip controller reading contacts every step. Prints steps/s and the
cost ratios off/native, off/python, off/python+grip.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import trimesh

from manigrasp import hands
from manigrasp.control import GripController, ImpedanceController, NativeImpedance, default_gains
from manigrasp.objects import build_object
from manigrasp.sim import Scene, build_scene, grip_force, read_hand_contacts


def _grasp_pose(scene: Scene) -> np.ndarray:
    pose = np.eye(4)
    pose[:3, 3] = [0.0, 0.0, scene.object_rest_height]
    if scene.hand.kind == "parallel":
        pose[:3, :3] = np.diag([1.0, -1.0, -1.0])
        return pose
    tcp = scene.tcp_pose()
    thumb = scene.model.body(f"hand/{scene.hand.finger_bodies[0]}").id
    side = np.sign((tcp[:3, :3].T @ (scene.data.xipos[thumb] - tcp[:3, 3]))[0]) or 1.0
    pose[:3, :3] = np.column_stack([[0.0, 0.0, side], [0.0, -side, 0.0], [1.0, 0.0, 0.0]])
    return pose


def _holding(scene: Scene) -> tuple[ImpedanceController, np.ndarray]:
    pose = _grasp_pose(scene)
    scene.reset(mount=pose, synergy=1.0)
    ctrl = ImpedanceController(scene.base, default_gains(scene.base))
    ctrl.set_target(pose)
    for _ in range(400 if scene.hand.kind == "parallel" else 1000):
        ctrl.apply()
        scene.step()
    pose[2, 3] += 0.05
    ctrl.set_target(pose, feedforward=np.r_[0, 0, scene.object_mass() * 9.81, 0, 0, 0])
    for _ in range(300):
        ctrl.apply()
        scene.step()
    return ctrl, scene.data.qpos.copy()


def _passive_base(scene: Scene, ctrl: ImpedanceController, on: bool) -> None:
    """Controller off: MuJoCo's own joint springs/dampers (same K, D) hold the base where it is."""
    m, joints = scene.model, m_joints(scene)
    m.jnt_stiffness[joints] = ctrl.gains.stiffness if on else 0.0
    m.dof_damping[scene.base.dofs] = ctrl.gains.damping if on else 0.0
    m.qpos_spring[scene.base_qpos] = scene.data.qpos[scene.base_qpos] if on else 0.0
    scene.data.ctrl[scene.base.actuators] = ctrl.generalized_forces(ctrl.feedforward + ctrl.gravity_wrench()) \
        if on else 0.0


def m_joints(scene: Scene) -> np.ndarray:
    """Joint ids of the six base joints."""
    return scene.model.dof_jntid[scene.base.dofs]


def _native_rate(scene: Scene, ctrl: ImpedanceController, steps: int, period: int) -> float:
    native = NativeImpedance(scene.base, ctrl.gains)
    native.engage()
    start = time.perf_counter()
    done = 0
    while done < steps:
        native.track(ctrl.target, ctrl.target_velocity, ctrl.feedforward)
        k = min(period, steps - done)
        scene.step(k)
        done += k
    rate = steps / (time.perf_counter() - start)
    native.release()
    return rate


def _rate(scene: Scene, state: np.ndarray, ctrl: ImpedanceController, mode: str, steps: int, period: int) -> float:
    scene.data.qpos[:], scene.data.qvel[:] = state, 0.0
    scene.forward()
    ctrl.apply()
    if mode == "native":
        scene.data.ctrl[scene.base.actuators] = 0.0
        rate = _native_rate(scene, ctrl, steps, period)
        if scene.warnings() or not scene.is_finite():
            raise RuntimeError(f"{scene.hand.name} {mode}: unstable {scene.warnings()}")
        return rate
    if mode == "off":
        _passive_base(scene, ctrl, True)
    grip = GripController(0.5 * scene.hand.max_grip_force, scene.hand.max_grip_force)
    dt = scene.model.opt.timestep
    start = time.perf_counter()
    for _ in range(steps):
        if mode != "off":
            ctrl.apply()
        if mode == "grip":
            scene.set_synergy(grip.update(grip_force(read_hand_contacts(scene)), dt))
        scene.step()
    rate = steps / (time.perf_counter() - start)
    if mode == "off":
        _passive_base(scene, ctrl, False)
    if scene.warnings() or not scene.is_finite():
        raise RuntimeError(f"{scene.hand.name} {mode}: unstable {scene.warnings()}")
    return rate


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=2000, help="timed steps per mode")
    parser.add_argument("--hands", nargs="*", default=None, help="hand names (default: all registered)")
    parser.add_argument("--control-period", type=int, default=5, help="steps between native set-point updates")
    args = parser.parse_args()
    objects = {
        "parallel": build_object(trimesh.creation.box((0.05,) * 3), name="box", mass=0.3).asset,
        "dexterous": build_object(trimesh.creation.cylinder(0.033, 0.12, sections=48), name="can", mass=0.35).asset,
    }
    print(f"{'hand':15s} {'ncon':>5s} {'off [steps/s]':>14s} {'native':>8s} {'python':>8s} {'+grip':>8s} "
          f"{'off/native':>10s} {'off/python':>10s} {'off/+grip':>9s}")
    for name in args.hands or hands.names():
        hand = hands.load(name)
        scene = build_scene(hand, objects[hand.kind])
        ctrl, state = _holding(scene)
        rates = {mode: _rate(scene, state, ctrl, mode, args.steps, args.control_period)
                 for mode in ("off", "native", "impedance", "grip")}
        print(f"{name:15s} {scene.data.ncon:5d} {rates['off']:14.0f} {rates['native']:8.0f} {rates['impedance']:8.0f} "
              f"{rates['grip']:8.0f} {rates['off'] / rates['native']:10.2f} {rates['off'] / rates['impedance']:10.2f} "
              f"{rates['off'] / rates['grip']:9.2f}")


if __name__ == "__main__":
    main()
