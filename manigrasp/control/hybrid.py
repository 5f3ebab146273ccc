"""Hybrid position/force control with a selection matrix, and its two uses.

The law, per axis i of the TCP frame (S = diag(s), s_i = 1: position, 0: force):

    u = S u_pos + (I - S) u_force
    u_pos   = K (x_d - x) + D (v_d - v)                        (the impedance law)
    u_force = f_d + k_p (f_d - f) + k_i z - d_f v,  z = integral of (f_d - f) dt

f is the force the hand exerts on its environment (what a wrist sensor
reads), so in a static contact u_force = f and the feed-forward f_d alone
already meets the target; the integral removes what the model misses. The
textbook's version sums the force error without a time step (its gain then
depends on the control rate) and lets the sum grow without bound while the
output is saturated (windup). Here the integral is over time (`dt` [s]) and
has anti-windup twice over: it is clamped so |k_i z| <= `integral_limit`, and
it stops integrating while the output is saturated in the error's direction.

Uses:
- `GuardedApproach`: move the TCP along its approach axis; when the contact
  force along approach reaches a threshold, that axis switches to force
  control at the threshold (stop pushing), the others keep their position.
- `GripController`: close the fingers on position (the synergy ramps toward
  closed) until the grip force rises, then regulate the grip force by PI
  action on the synergy (a 1-D selection switching from position to force).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from manigrasp.control.impedance import ImpedanceController, ImpedanceGains
from manigrasp.errors import ConfigError
from manigrasp.geometry import check_rigid
from manigrasp.sim.scene import FloatingBase


class ForcePI:
    """Vectorised PI on force error with clamped, conditional integration (anti-windup).

    Args:
        kp: (n,) proportional gains [output / N].
        ki: (n,) integral gains [output / (N s)].
        integral_limit: (n,) bound on |ki z| [output units].
    """

    def __init__(self, kp: np.ndarray | float, ki: np.ndarray | float, integral_limit: np.ndarray | float,
                 n: int = 1) -> None:
        self.kp = np.broadcast_to(np.asarray(kp, float), (n,)).copy()
        self.ki = np.broadcast_to(np.asarray(ki, float), (n,)).copy()
        self.limit = np.broadcast_to(np.asarray(integral_limit, float), (n,)).copy()
        if np.any(self.kp < 0) or np.any(self.ki < 0) or np.any(self.limit < 0):
            raise ConfigError("PI gains and integral limits must be >= 0")
        self.integral = np.zeros(n)

    def reset(self) -> None:
        """Zero the integral state."""
        self.integral[:] = 0.0

    def update(self, error: np.ndarray | float, dt: float, push_up_blocked: np.ndarray | bool = False,
               push_down_blocked: np.ndarray | bool = False) -> np.ndarray:
        """(n,) PI output for `error` (n,) over a step `dt` [s].

        `push_up_blocked` / `push_down_blocked` say where the actuator output is
        already saturated high / low; the integral does not grow further in that direction.
        """
        if dt <= 0:
            raise ValueError(f"dt must be > 0, got {dt}")
        error = np.asarray(error, float)
        frozen = (np.asarray(push_up_blocked) & (error > 0)) | (np.asarray(push_down_blocked) & (error < 0))
        self.integral = np.where(frozen, self.integral, self.integral + error * dt)
        bound = np.divide(self.limit, self.ki, out=np.zeros_like(self.limit), where=self.ki > 0)
        self.integral = np.clip(self.integral, -bound, bound)
        return self.kp * error + self.ki * self.integral


@dataclass(frozen=True)
class ForceGains:
    """Gains of the force-controlled axes of `HybridController` (TCP frame, 6 axes).

    Attributes:
        kp: (6,) proportional gains on force error [-] (N per N).
        ki: (6,) integral gains [1/s].
        integral_limit: (6,) bound on the integral term [N] x3, [N m] x3.
        damping: (6,) active damping on force axes [N s/m] x3, [N m s/rad] x3.
    """

    kp: np.ndarray | float = 0.2
    ki: np.ndarray | float = 20.0
    integral_limit: np.ndarray | float = 10.0
    damping: np.ndarray | float = 20.0

    def __post_init__(self) -> None:
        for name in ("kp", "ki", "integral_limit", "damping"):
            value = np.broadcast_to(np.asarray(getattr(self, name), float), (6,)).copy()
            if not np.all(np.isfinite(value)) or np.any(value < 0):
                raise ConfigError(f"ForceGains.{name} must be finite and >= 0, got {value}")
            object.__setattr__(self, name, value)


class HybridController:
    """Selection-matrix hybrid position/force control of the floating hand (TCP frame).

    Args:
        base: the scene's floating base view.
        gains: impedance gains of the position-controlled axes.
        force_gains: PI gains of the force-controlled axes.
        selection: (6,) 1 = position-controlled, 0 = force-controlled, per TCP axis
            (x, y, z, rx, ry, rz).
    """

    def __init__(self, base: FloatingBase, gains: ImpedanceGains, force_gains: ForceGains,
                 selection: np.ndarray) -> None:
        self.base = base
        self.impedance = ImpedanceController(base, gains)
        self.force_gains = force_gains
        self.pi = ForcePI(force_gains.kp, force_gains.ki, force_gains.integral_limit, n=6)
        self.selection = np.ones(6)
        self.set_selection(selection)
        self.target_wrench = np.zeros(6)

    def set_selection(self, selection: np.ndarray) -> None:
        """Set S: (6,) of 0/1 (1 position, 0 force), TCP frame."""
        sel = np.asarray(selection, float).reshape(6)
        if not np.all((sel == 0) | (sel == 1)):
            raise ConfigError(f"selection entries must be 0 or 1, got {sel}")
        self.selection = sel

    def set_target(self, pose: np.ndarray, wrench: np.ndarray | None = None) -> None:
        """Target TCP `pose` (4, 4) for position axes, `wrench` (6,) TCP frame for force axes.

        The wrench is what the hand should exert on its environment [N, N m].
        """
        self.impedance.set_target(check_rigid(pose, "target pose"))
        self.target_wrench = np.zeros(6) if wrench is None else np.asarray(wrench, float).reshape(6)

    def compute(self, measured: np.ndarray, dt: float) -> np.ndarray:
        """(6,) base motor commands, given the `measured` wrench (6,) the hand exerts, TCP frame."""
        _, rot, v, w = self.impedance.tcp_state()
        rot6 = np.kron(np.eye(2), rot)  # block-diagonal: world <- TCP for force and torque
        u_pos = rot6.T @ self.impedance.spring_damper()
        error = self.target_wrench - np.asarray(measured, float).reshape(6)
        twist = np.concatenate([rot.T @ v, rot.T @ w])
        u_force = self.target_wrench + self.pi.update(error, dt) - self.force_gains.damping * twist
        u_force = np.where(self.selection == 0, u_force, 0.0)
        self.pi.integral[self.selection == 1] = 0.0
        u = self.selection * u_pos + u_force
        world = rot6 @ u + self.impedance.gravity_wrench()
        return self.impedance.generalized_forces(world)

    def apply(self, measured: np.ndarray, dt: float) -> np.ndarray:
        """`compute` and write the commands to the base motors; returns them."""
        u = self.compute(measured, dt)
        self.base.data.ctrl[self.base.actuators] = u
        return u


class GuardedApproach:
    """Approach along the TCP z axis at `speed`; stop pushing once the contact force hits `threshold`.

    Args:
        base: floating base view.
        gains: impedance gains (all axes position-controlled before contact).
        force_gains: PI gains used on the approach axis after the guard trips.
        threshold: contact force along approach that stops the approach [N].
        speed: approach speed of the moving set-point [m/s].
    """

    def __init__(self, base: FloatingBase, gains: ImpedanceGains, force_gains: ForceGains,
                 threshold: float, speed: float = 0.05) -> None:
        if threshold <= 0 or speed <= 0:
            raise ConfigError("threshold and speed must be > 0")
        self.hybrid = HybridController(base, gains, force_gains, np.ones(6))
        self.threshold, self.speed = threshold, speed
        self.start, self.goal = np.eye(4), np.eye(4)
        self.travelled = 0.0
        self.tripped = False

    def begin(self, start: np.ndarray, goal: np.ndarray) -> None:
        """Start a new approach from pose `start` to pose `goal` (both (4, 4), same orientation)."""
        self.start, self.goal = check_rigid(start, "start").copy(), check_rigid(goal, "goal").copy()
        self.travelled, self.tripped = 0.0, False
        self.hybrid.set_selection(np.ones(6))
        self.hybrid.pi.reset()

    @property
    def distance(self) -> float:
        """Length of the approach [m]."""
        return float(np.linalg.norm(self.goal[:3, 3] - self.start[:3, 3]))

    @property
    def reached(self) -> bool:
        """True once the set-point has arrived at the goal."""
        return self.travelled >= self.distance

    def compute(self, measured: np.ndarray, dt: float) -> np.ndarray:
        """(6,) base commands; `measured` is the hand's contact wrench (6,) in the TCP frame."""
        if not self.tripped and measured[2] >= self.threshold:
            self.tripped = True
            self.hybrid.set_selection(np.array([1, 1, 0, 1, 1, 1]))
        if not self.tripped:
            self.travelled = min(self.distance, self.travelled + self.speed * dt)
        setpoint = self.goal.copy()
        frac = self.travelled / self.distance if self.distance > 0 else 1.0
        setpoint[:3, 3] = self.start[:3, 3] + frac * (self.goal[:3, 3] - self.start[:3, 3])
        self.hybrid.set_target(setpoint, np.array([0, 0, self.threshold, 0, 0, 0]))
        return self.hybrid.compute(measured, dt)

    def apply(self, measured: np.ndarray, dt: float) -> np.ndarray:
        """`compute` and write the commands to the base motors; returns them."""
        u = self.compute(measured, dt)
        self.hybrid.base.data.ctrl[self.hybrid.base.actuators] = u
        return u


REARM_SYNERGY = 0.02  # [-] fingers this far past a lost contact (2.3 mm of parallel_jaw's width): close on
BRUSH_FRACTION = 0.5  # [-] a lost contact whose grip force never reached this fraction of the target was a brush
STALL_SYNERGY, STALL_S = 1e-3, 0.1  # [-], [s] fingers that advance less than this for this long have stopped


class GripController:
    """Hybrid closing of a hand's synergy: position until contact, then grip-force regulation.

    Position phase (S = 1): the synergy command ramps toward 1 at
    `close_speed`. Contact (grip force >= `contact_force`) switches to the
    force phase (S = 0) at the contact synergy s_c, where the grip force
    grows as k (s - s_c) [N] (k in N per unit synergy) until the hand's force
    limit. The synergy follows

        s = s_c + (f_ff + kp e + ki z) / k,  e = F_d - F [N], z = integral of e dt,

    so the loop bandwidth `bandwidth` [1/s] is the same for every hand and width.

    - A hand whose servo stiffness is known (`stiffness`, a hand's
      `grip_stiffness`: kp x command span x transmission, e.g. 2000 N/m x
      11.5 cm = 230 N for `parallel_jaw`) pushes with k (s - s_h), s_h where
      its fingers are (`hand_synergy`), so s_c is s_h at every tick (the
      contact synergy while they stand on the object, and where they are while
      the object still yields or the pads compress), and the feed-forward
      f_ff = F_d commands the target force at once: the servo is force
      controlled, as a real gripper's grasp command is; the integral removes
      what the model misses (friction, a transmission that varies over the
      stroke). This needs a closed command past the closed stop (the servo
      reaches the force limit at any width).
    - Otherwise k = full_force / (1 - s_c) estimates it (linear from contact
      to `full_force` at s = 1), s_c is the command at contact and f_ff = 0.
      The estimate holds when the hand's force grows over the remaining
      synergy, as for the soft tendon servos of the dexterous hands
      (`manigrasp.hands.from_robosuite.dexterous`: a blocked finger pushes
      with kp (u - L), so the force spreads over a third of the command
      range); a stiff servo that jumps to its force limit within a few
      percent of the synergy would make the loop gain tens of times too high
      and oscillate, and a position servo whose closed command is the closed
      stop (force kp x width) would make it too low on narrow grips.

    The synergy is clamped to [0, 1]; the integral freezes while it is clamped
    (anti-windup).

    The grip force is `manigrasp.sim.grip_force`: the squeeze between the first
    finger (jaw 1, or the thumb) and the rest of the hand, so contact means a
    two-sided grasp, not one finger pushing the object away.

    Args:
        target_force: grip force to hold [N] (as `manigrasp.sim.grip_force` measures it).
        full_force: grip force of the fully closed command on an object [N]
            (a hand's `max_grip_force`).
        close_speed: synergy rate of the position phase [1/s].
        contact_force: grip force that counts as contact [N].
        bandwidth: integral gain of the force loop, normalised by k [1/s].
        kp: proportional gain of the force loop, normalised by k [-].
        lead: how far the position-phase command may at least run ahead of the hand synergy (`update`).
        stiffness: k [N per unit synergy] of the hand's servo (`Hand.grip_stiffness`); None: estimated.
        stall_check: whether a position phase whose fingers stop moving is `stalled` (None: when the
            `stiffness` is known; the protocol sets it for every parallel-jaw hand).
    """

    def __init__(self, target_force: float, full_force: float, close_speed: float = 1.0,
                 contact_force: float = 0.5, bandwidth: float = 10.0, kp: float = 0.1, lead: float = 0.1,
                 stiffness: float | None = None, stall_check: bool | None = None) -> None:
        if not 0 < target_force <= full_force or close_speed <= 0 or contact_force <= 0:
            raise ConfigError("need 0 < target_force <= full_force, close_speed > 0 and contact_force > 0")
        if stiffness is not None and not (np.isfinite(stiffness) and stiffness > 0):
            raise ConfigError(f"the grip stiffness must be finite and > 0 (or None), got {stiffness}")
        self.target_force, self.full_force, self.close_speed = target_force, full_force, close_speed
        self.contact_force, self.bandwidth, self.kp, self.lead = contact_force, bandwidth, kp, lead
        self.servo_stiffness = stiffness
        self.stall_check = stiffness is not None if stall_check is None else bool(stall_check)
        self.reset()

    def reset(self, synergy: float = 0.0) -> None:
        """Start a new closing from `synergy` (0 = open)."""
        self.synergy = float(synergy)
        self.mode = "position"
        self.contact_synergy = np.nan
        self.stiffness = np.nan
        self.feedforward = 0.0
        self.pi = ForcePI(self.kp, self.bandwidth, np.inf)
        self._furthest, self._still_s, self._peak = -np.inf, 0.0, 0.0

    @property
    def stalled(self) -> bool:
        """True (with `stall_check`) when the hand is still closing on position but its fingers have not
        moved on (by STALL_SYNERGY of the mean hand synergy) for STALL_S: closed on nothing, they rest on
        their stops (a closed command past the stop, or a linkage whose pads meet before its joint limits,
        never reaches synergy 1), or on one side of an object that does not move."""
        return self.mode == "position" and self._still_s >= STALL_S

    @property
    def peak_force(self) -> float:
        """The largest grip force [N] measured in the force phase since the last reset (0 before contact)."""
        return float(self._peak)

    def update(self, grip_force: float, dt: float, hand_synergy: float | None = None,
               reach: float | None = None) -> float:
        """New synergy command for the measured `grip_force` [N] after a step `dt` [s].

        `hand_synergy` (e.g. `Scene.hand_synergy()`: the mean over the fingers
        that move), if given, keeps the position-phase command at most
        max(`hand_synergy` + `lead`, `reach`) (`reach`, e.g.
        `Scene.closing_reach()`: the furthest command that drives no finger's
        servo past its force limit), so a slow hand does not find the command
        already closed at contact. The reach, not only `lead`: a soft servo (the
        dexterous hands' tendons, 0.5 N m/rad) follows a ramp with a lag of
        the ramp rate times its time constant, so a fixed `lead` sets how fast
        it closes (0.09 of the synergy per second for the Fourier hand at 0.1:
        a can is not reached in the 2 s close), while a lead up to its force
        limit is what the servo can use (the five-finger hands
        closed fast enough before only because their fixed thumb rotation
        counted as closed, adding (1 - s) / 6 to the lead). `hand_synergy` is
        also what `stall_check` watches; with a known `stiffness` it is also
        the contact synergy s_c, and a contact that is lost while the fingers
        move on past it by `REARM_SYNERGY`, its grip force never above
        `BRUSH_FRACTION` of the target (a brush of a rim or a handle on the way
        in), returns to the position phase, so the force phase starts again
        where the fingers meet the object. An object that was gripped and
        squeezed out stays in the force phase (the protocol judges it).
        """
        if self.mode == "force":
            self._peak = max(self._peak, grip_force)
            if (self.servo_stiffness is not None and hand_synergy is not None and grip_force < self.contact_force
                    and hand_synergy > self.contact_synergy + REARM_SYNERGY
                    and self._peak < BRUSH_FRACTION * self.target_force):
                self.reset(min(self.synergy, hand_synergy + self.lead))  # the contact was a brush: close on
        if self.mode == "position":
            if grip_force < self.contact_force:
                if hand_synergy is not None and self.stall_check:
                    moved = hand_synergy > self._furthest + STALL_SYNERGY
                    self._furthest = hand_synergy if moved else self._furthest
                    self._still_s = 0.0 if moved else self._still_s + dt
                ceiling = 1.0 if hand_synergy is None else max(hand_synergy + self.lead,
                                                               -np.inf if reach is None else reach)
                self.synergy = min(1.0, ceiling, self.synergy + self.close_speed * dt)
                return self.synergy
            self.mode = "force"
            if self.servo_stiffness is None:
                self.contact_synergy = self.synergy
                self.stiffness = self.full_force / max(1.0 - self.synergy, 0.05)
            else:  # command the target at once; the force read at this tick is the position phase's: not integrated
                self.contact_synergy = self.synergy if hand_synergy is None else min(self.synergy, hand_synergy)
                self.stiffness = self.servo_stiffness
                self.feedforward = self.target_force / self.stiffness
                self.synergy = float(np.clip(self.contact_synergy + self.feedforward, 0.0, 1.0))
                return self.synergy
        error = (self.target_force - grip_force) / self.stiffness
        out = self.pi.update(error, dt, push_up_blocked=self.synergy >= 1.0, push_down_blocked=self.synergy <= 0.0)
        # a known servo pushes with k (s - where the fingers are): command that push from where they are now
        base = self.contact_synergy if self.servo_stiffness is None or hand_synergy is None else hand_synergy
        self.synergy = float(np.clip(base + self.feedforward + out[0], 0.0, 1.0))
        return self.synergy
