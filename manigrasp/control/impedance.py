"""Cartesian impedance of the floating hand, computed in Python every step.

The protocols use `manigrasp.control.native.NativeImpedance` instead: the same
law on the base joints, evaluated by MuJoCo's own servos, so nothing runs in
Python between set-point updates. This class remains the position part of
`HybridController` and `GuardedApproach` (which need a measured contact
wrench every step anyway) and supports adaptive stiffness.

The law (world frame, TCP frame axes for the gains):

    F   = K_t (x_d - x) + D_t (v_d - v) + F_ff + F_g
    tau = K_r log(R_d R^T) + D_r (w_d - w) + tau_ff

with x, R, v, w the TCP position, orientation, linear and angular velocity;
K_t = R diag(k_t) R^T and likewise D_t, K_r, D_r (per-axis gains in the
current TCP frame); F_g = -m g the hand's weight when MuJoCo does not
compensate it; F_ff, tau_ff a feed-forward wrench (e.g. a held object's
weight). The wrench is a *spring and damper pulling toward the target*: the
textbook's version multiplies K and D by an inertia matrix (mixing units) and
with its error sign pushes away from the target; this one does neither.

How the floating base is realised in MuJoCo (see `manigrasp.sim.compose`):
six joints on the hand's root body (three slides along the TCP axes of the
mount, then three hinges about those axes through the hand's centre of mass),
each driven by a `motor` actuator; the commands are `J^T [F; tau]` where the
force acts *through the rotation centre* (the hand's centre of mass) and tau
is the torque. Why:
- A force through the centre of mass moves the hand without turning it, so
  each translational axis is exactly the designed mass-spring-damper
  m x'' + D x' + K x = K x_d with m the hand mass (tested); applied at the TCP
  it would also twist the hand (TCP and COM are ~5-10 cm apart).
- Joints rather than a free body plus `xfrc_applied`: zero base joints put the
  TCP on the *mount* pose, which is moved between trials by editing the root
  body's pose in the model (no recompile); the base shows up in
  `qpos`/`actuator_force` like any robot, and the commands are actuator
  controls that a recording replays. Euler-angle hinges are singular only at
  90 degrees of pitch away from the mount, far outside the 15 degrees a trial
  tolerates.
- Gravity compensation of the hand is MuJoCo's body `gravcomp` (exact, no
  Python cost) unless the scene was built with `hand_gravcomp=False`, in which
  case this controller adds F_g itself.

Cost per step: one `mj_jacSite` and `mj_jac` (3 x nv each) and a few 3x3
products, about 20-40 us of Python on top of `mj_step` (the native servos:
none; benchmarks/bench_sim_speed.py measures both). Damping is computed explicitly,
so keep D_r dt / I below ~1 (`ImpedanceGains.design` does).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from manigrasp.errors import ConfigError
from manigrasp.geometry import check_rigid, rotation_error
from manigrasp.sim.scene import FloatingBase


def _vec(value: np.ndarray | float, n: int, name: str) -> np.ndarray:
    arr = np.broadcast_to(np.asarray(value, float), (n,)).copy()
    if not np.all(np.isfinite(arr)) or np.any(arr < 0):
        raise ConfigError(f"{name} must be finite and >= 0, got {arr}")
    return arr


@dataclass(frozen=True)
class ImpedanceGains:
    """Per-axis gains in the TCP frame.

    Attributes:
        stiffness: (6,) [N/m] x3 (x, y, z), then [N m/rad] x3 (about x, y, z).
        damping: (6,) [N s/m] x3, then [N m s/rad] x3.
    """

    stiffness: np.ndarray
    damping: np.ndarray

    def __post_init__(self) -> None:
        object.__setattr__(self, "stiffness", _vec(self.stiffness, 6, "stiffness"))
        object.__setattr__(self, "damping", _vec(self.damping, 6, "damping"))

    @classmethod
    def design(cls, mass: float, inertia: float | np.ndarray, omega: float = 40.0, omega_rot: float = 60.0,
               zeta: float = 1.0, zeta_rot: float = 1.0) -> ImpedanceGains:
        """Gains giving natural frequencies `omega`, `omega_rot` [rad/s] and damping ratios.

        k = m omega^2, d = 2 zeta m omega (likewise with the rotational inertia
        `inertia` [kg m^2], a scalar or (3,) about the TCP axes).
        """
        inertia = np.broadcast_to(np.asarray(inertia, float), (3,))
        k = np.concatenate([np.full(3, mass * omega**2), inertia * omega_rot**2])
        d = np.concatenate([np.full(3, 2 * zeta * mass * omega), 2 * zeta_rot * inertia * omega_rot])
        return cls(stiffness=k, damping=d)


@dataclass(frozen=True)
class AdaptiveStiffness:
    """Stiffness raised with tracking error (the textbook's idea, with units made explicit).

    factor = min(max_factor, 1 + |e| / error_scale), separately for translation
    (|e| [m] against `error_scale` [m]) and rotation (|e| [rad] against
    `rot_error_scale` [rad]); damping is scaled by sqrt(factor) so the damping
    ratio stays as designed.
    """

    error_scale: float = 0.02
    rot_error_scale: float = 0.2
    max_factor: float = 2.0

    def __post_init__(self) -> None:
        if self.error_scale <= 0 or self.rot_error_scale <= 0 or self.max_factor < 1:
            raise ConfigError("error scales must be > 0 and max_factor >= 1")

    def factors(self, pos_error: float, rot_error: float) -> tuple[float, float]:
        """(translational, rotational) stiffness factors for error norms [m], [rad]."""
        ft = min(self.max_factor, 1.0 + pos_error / self.error_scale)
        fr = min(self.max_factor, 1.0 + rot_error / self.rot_error_scale)
        return ft, fr


class ImpedanceController:
    """Cartesian impedance of the hand's TCP on a `FloatingBase` (see the module docstring).

    Args:
        base: the scene's floating base view (`scene.base`).
        gains: per-axis TCP-frame gains.
        adaptive: raise stiffness with tracking error, or None for fixed gains.
    """

    def __init__(self, base: FloatingBase, gains: ImpedanceGains, adaptive: AdaptiveStiffness | None = None) -> None:
        self.base, self.gains, self.adaptive = base, gains, adaptive
        nv = base.model.nv
        self._jacp, self._jacr = np.zeros((3, nv)), np.zeros((3, nv))
        self._jacc = np.zeros((3, nv))
        self.target = np.eye(4)
        self.target_velocity = np.zeros(6)
        self.feedforward = np.zeros(6)
        self.stiffness_factors = (1.0, 1.0)

    def set_target(self, pose: np.ndarray, velocity: np.ndarray | None = None,
                   feedforward: np.ndarray | None = None) -> None:
        """Target TCP `pose` (4, 4), twist `velocity` (6,) [m/s, rad/s] and feed-forward wrench (6,), world."""
        self.target = check_rigid(pose, "target pose").copy()
        self.target_velocity = np.zeros(6) if velocity is None else np.asarray(velocity, float).reshape(6)
        self.feedforward = np.zeros(6) if feedforward is None else np.asarray(feedforward, float).reshape(6)

    def tcp_state(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """TCP (position (3,), rotation (3, 3), linear velocity (3,), angular velocity (3,)), world."""
        m, d, site = self.base.model, self.base.data, self.base.tcp_site
        mujoco.mj_jacSite(m, d, self._jacp, self._jacr, site)
        return (d.site_xpos[site].copy(), d.site_xmat[site].reshape(3, 3).copy(),
                self._jacp @ d.qvel, self._jacr @ d.qvel)

    def wrench(self) -> np.ndarray:
        """(6,) world wrench [F; tau] of the whole law: spring-damper + feed-forward + gravity."""
        return self.spring_damper() + self.feedforward + self.gravity_wrench()

    def gravity_wrench(self) -> np.ndarray:
        """(6,) world wrench holding the hand's weight: zero when MuJoCo's gravcomp does it."""
        out = np.zeros(6)
        if not self.base.gravcomp:
            out[:3] = -self.base.mass * self.base.model.opt.gravity
        return out

    def spring_damper(self) -> np.ndarray:
        """(6,) world wrench K (x_d - x) + D (v_d - v) for the current state (adaptive K if set)."""
        x, rot, v, w = self.tcp_state()
        e_p = self.target[:3, 3] - x
        e_r = rotation_error(self.target[:3, :3], rot)
        ft, fr = self.adaptive.factors(float(np.linalg.norm(e_p)), float(np.linalg.norm(e_r))) \
            if self.adaptive else (1.0, 1.0)
        self.stiffness_factors = (ft, fr)
        k, dmp = self.gains.stiffness, self.gains.damping
        force = rot @ (ft * k[:3] * (rot.T @ e_p) + np.sqrt(ft) * dmp[:3] * (rot.T @ (self.target_velocity[:3] - v)))
        torque = rot @ (fr * k[3:] * (rot.T @ e_r) + np.sqrt(fr) * dmp[3:] * (rot.T @ (self.target_velocity[3:] - w)))
        return np.concatenate([force, torque])

    def generalized_forces(self, wrench: np.ndarray) -> np.ndarray:
        """(6,) base joint forces realising world `wrench` (force through the COM anchor, torque)."""
        m, d = self.base.model, self.base.data
        anchor = d.xanchor[self.base.anchor_joint]
        mujoco.mj_jac(m, d, self._jacc, self._jacr, anchor, self.base.root_body)
        dofs = self.base.dofs
        return self._jacc[:, dofs].T @ wrench[:3] + self._jacr[:, dofs].T @ wrench[3:]

    def compute(self) -> np.ndarray:
        """(6,) base motor commands of the law for the current state."""
        return self.generalized_forces(self.wrench())

    def apply(self) -> np.ndarray:
        """Compute the commands and write them to `data.ctrl` of the base motors; returns them."""
        u = self.compute()
        self.base.data.ctrl[self.base.actuators] = u
        return u


def default_gains(base: FloatingBase, omega: float = 40.0, omega_rot: float = 100.0) -> ImpedanceGains:
    """Critically damped gains for this hand: `omega`, `omega_rot` [rad/s] on its mass and
    inertia about the base hinges (`base.diag_inertia()`, valid after `mj_forward`)."""
    inertia = base.diag_inertia()
    return ImpedanceGains.design(base.mass, inertia[3:], omega=omega, omega_rot=omega_rot)
