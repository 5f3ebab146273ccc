"""Cartesian impedance of the floating hand computed by MuJoCo: PD servos on the six base joints.

The protocol's controller. Each base joint (`manigrasp.sim.compose`: slides
tx, ty, tz along the mount's TCP axes, then hinges rx, ry, rz about those axes
through the open hand's centre of mass) carries a `general` actuator with gain
kp and affine bias -kp q - kv qdot, so MuJoCo applies, every step,

    tau_i = kp_i (u_i - q_i) - kv_i qdot_i,   u_i = q_d,i + (kv_i / kp_i) qdot_d,i + f_i / kp_i

that is the impedance law K (q_d - q) + D (qdot_d - qdot) + f on that joint,
with the set-point q_d, its rate qdot_d and a feed-forward force f folded into
the one command u_i that Python writes when a set-point changes. Between
set-point updates nothing runs in Python: the protocol steps in chunks
(`mujoco.mj_step(model, data, nstep=k)`). `implicitfast` integrates the
damping term implicitly (its velocity derivative is part of the implicit
step), so any kv is stable at the 2 ms step.

How it relates to `ImpedanceController` (the Python law, kept for the
hybrid force controller and the guarded approach):
- Translation: a slide force is a force through the rotation centre (the
  hand's centre of mass), exactly what `ImpedanceController` applies, so each
  translational axis is the designed mass-spring-damper m x'' + D x' + K x =
  K x_d with m the hand's mass (tested: 5 cm steps along each axis). The
  stiffness acts on the rotation centre's position rather than the TCP's; the
  two coincide while the hand is not turned from its set-point.
- Rotation: the stiffness acts on the three Euler angles of the hand relative
  to the mount (intrinsic x-y-z, the order of the hinges) instead of on
  log(R_d R^T); the two agree to first order, and within 1 % up to the
  15 degrees a trial tolerates.
- Set-points are TCP poses, turned into joint set-points in closed form
  (`BaseKinematics`), so a protocol thinks in TCP poses as before.

Cost: a set-point update is ~20 us of Python; a step costs what `mj_step`
costs (benchmarks/bench_sim_speed.py measures both controllers).
"""

from __future__ import annotations

import math

import numpy as np

from manigrasp.control.impedance import ImpedanceGains
from manigrasp.errors import ConfigError
from manigrasp.geometry import axis_angle_to_mat, check_rigid
from manigrasp.sim.scene import FloatingBase

_FD_STEP = 1e-4  # [s] finite-difference step of the set-point rate


def euler_xyz(rot: np.ndarray) -> np.ndarray:
    """(3,) intrinsic x-y-z Euler angles [rad] of `rot` (3, 3) = Rx(a) Ry(b) Rz(c); |b| < 90 deg."""
    b = math.asin(max(-1.0, min(1.0, float(rot[0, 2]))))
    a = math.atan2(-float(rot[1, 2]), float(rot[2, 2]))
    c = math.atan2(-float(rot[0, 1]), float(rot[0, 0]))
    return np.array([a, b, c])


class BaseKinematics:
    """Closed-form map between TCP poses and the six base joint positions.

    With the mount M (TCP pose at zero joints) and the rotation centre c' (the
    hinges' anchor, in the mount's TCP frame), joints (t, theta) put the TCP at
    M [R, t + c' - R c'] with R = Rx(theta_x) Ry(theta_y) Rz(theta_z) (MuJoCo
    composes a body's joints in order, each about the axes the previous ones
    turned). So a TCP target T gives theta = euler_xyz(R) and t = p - c' + R c'
    with [R, p] = M^-1 T.

    Args:
        base: the floating base view; the mount is read from the model now
            (build a new one after `Scene.set_mount`).
    """

    def __init__(self, base: FloatingBase) -> None:
        self.mount = base.mount()
        self.mount_inv = np.linalg.inv(self.mount)
        anchor_in_root = base.model.jnt_pos[base.anchor_joint]
        self.centre = np.linalg.inv(base.tcp_in_root)[:3, :3] @ (anchor_in_root - base.tcp_in_root[:3, 3])

    def joints(self, pose: np.ndarray) -> np.ndarray:
        """(6,) base joint positions [m x3, rad x3] that put the TCP at `pose` (4, 4), world."""
        rel = self.mount_inv @ pose
        rot = rel[:3, :3]
        return np.concatenate([rel[:3, 3] - self.centre + rot @ self.centre, euler_xyz(rot)])

    def joint_rates(self, pose: np.ndarray, twist: np.ndarray) -> np.ndarray:
        """(6,) joint velocities moving the TCP at `pose` with world `twist` (6,) [m/s, rad/s].

        A pure translation moves only the slides (exactly); a turn is differentiated numerically.
        """
        twist = np.asarray(twist, float)
        if not twist[3:].any():
            return np.concatenate([self.mount_inv[:3, :3] @ twist[:3], np.zeros(3)])
        ahead = pose.copy()
        ahead[:3, 3] += _FD_STEP * twist[:3]
        spin = float(np.linalg.norm(twist[3:]))
        ahead[:3, :3] = axis_angle_to_mat(twist[3:] / max(spin, 1e-300), _FD_STEP * spin) @ pose[:3, :3]
        return (self.joints(ahead) - self.joints(pose)) / _FD_STEP


class NativeImpedance:
    """Impedance of the hand's base realised by MuJoCo's base servos (see the module docstring).

    Args:
        base: the scene's floating base view (`scene.base`).
        gains: per-axis gains: stiffness kp and damping kv of the slides
            [N/m, N s/m] and hinges [N m/rad, N m s/rad] (e.g. `default_gains(base)`).
    """

    def __init__(self, base: FloatingBase, gains: ImpedanceGains) -> None:
        if np.any(gains.stiffness <= 0):
            raise ConfigError(f"NativeImpedance needs every stiffness > 0, got {gains.stiffness}")
        self.base, self.gains = base, gains
        self.kinematics = BaseKinematics(base)
        self.target = self.kinematics.mount.copy()
        self.target_velocity = np.zeros(6)
        self.feedforward = np.zeros(6)
        self._ff_joint = self.joint_forces(self.feedforward) / gains.stiffness

    def engage(self) -> None:
        """Write the gains into the base servos and switch the base motors off."""
        m, servos = self.base.model, self.base.servos
        m.actuator_gainprm[servos, 0] = self.gains.stiffness
        m.actuator_biasprm[servos, 0] = 0.0
        m.actuator_biasprm[servos, 1] = -self.gains.stiffness
        m.actuator_biasprm[servos, 2] = -self.gains.damping
        self.base.data.ctrl[self.base.actuators] = 0.0

    def release(self) -> None:
        """Switch the base servos off."""
        self.base.release_servos()

    def set_target(self, pose: np.ndarray, velocity: np.ndarray | None = None,
                   feedforward: np.ndarray | None = None) -> np.ndarray:
        """Target TCP `pose` (4, 4), twist `velocity` (6,) [m/s, rad/s] and feed-forward wrench (6,), world.

        The feed-forward wrench [N, N m] acts through the rotation centre (e.g. a held
        object's weight); without MuJoCo's gravity compensation the hand's weight is
        added. Writes and returns the servo commands u (6,).
        """
        check_rigid(pose, "target pose")
        return self.track(pose, velocity, np.zeros(6) if feedforward is None else feedforward)

    def track(self, pose: np.ndarray, velocity: np.ndarray | None = None,
              feedforward: np.ndarray | None = None) -> np.ndarray:
        """`set_target` without validating `pose`, and keeping the feed-forward if `feedforward` is None
        (for the set-points a trajectory generates at the control rate)."""
        self.target = np.array(pose, float)
        self.target_velocity = np.zeros(6) if velocity is None else np.asarray(velocity, float).reshape(6)
        if feedforward is not None and not np.array_equal(feedforward, self.feedforward):
            self.feedforward = np.asarray(feedforward, float).reshape(6).copy()
            self._ff_joint = self.joint_forces(self.feedforward) / self.gains.stiffness
        return self.command()

    def command(self) -> np.ndarray:
        """Write (and return) the servo commands u (6,) of the current target, twist and feed-forward."""
        kin, k, d = self.kinematics, self.gains.stiffness, self.gains.damping
        q = kin.joints(self.target)
        qdot = kin.joint_rates(self.target, self.target_velocity)
        u = q + d / k * qdot + self._ff_joint
        self.base.data.ctrl[self.base.servos] = u
        return u

    def joint_forces(self, wrench: np.ndarray) -> np.ndarray:
        """(6,) base joint forces of a world `wrench` (6,) through the rotation centre (+ the hand's
        weight when MuJoCo does not compensate it)."""
        force = np.array(wrench[:3], float)
        if not self.base.gravcomp:
            force -= self.base.mass * self.base.model.opt.gravity
        hinge_axes = self.base.data.xaxis[self.base.model.dof_jntid[self.base.dofs[3:]]]
        return np.concatenate([self.kinematics.mount[:3, :3].T @ force, hinge_axes @ np.asarray(wrench[3:], float)])

    def joint_error(self) -> np.ndarray:
        """(6,) set-point minus current base joint positions [m x3, rad x3]."""
        qpos = self.base.data.qpos[self.base.model.jnt_qposadr[self.base.model.dof_jntid[self.base.dofs]]]
        return self.kinematics.joints(self.target) - qpos
