"""The machinery every protocol shares: stepping with fault checks, and the grasp phases.

`TrialRun` owns the controllers of one trial and steps the scene with no
Python per step: MuJoCo computes the hand's impedance (the base servos of
`control.NativeImpedance`) and its finger servos every step, and Python acts
only at coarse ticks, stepping everything in between in one call
(`mj_step(..., nstep=k)`):

- control ticks (`GraspParams.control_period_s`, 100 Hz), only while a
  set-point moves or the grip loop runs: the set-point from the phase's
  trajectory, the grip-force loop while closing;
- checks (`check_period_s`, 50 Hz, and at the end of each stepping call):
  faults (non-finite state, MuJoCo warnings, divergence -> `unstable`; the
  wall-clock deadline -> `timeout`) and, while a phase watches it, the
  object's motion relative to the hand (-> the phase's failure status).

A fault ends the trial by raising `Abort`, which the protocol turns into its
`TrialResult`. An observer (`protocol.observer.TrialObserver`) only adds
stops at its sample times; it never moves a tick or a check, so a trial's
result is the same with or without one.

The phases themselves are in `manigrasp.protocol.phases`. Poses are (4, 4)
world matrices [m].
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from manigrasp.control import FingerClose, GripController, NativeImpedance, default_gains
from manigrasp.control.hold import HOLD_GAIN
from manigrasp.errors import ConfigError
from manigrasp.geometry import pose_distance, relative_pose
from manigrasp.protocol.grasp import PREGRASP_OFFSET, Grasp
from manigrasp.protocol.metrics import radius_of_gyration
from manigrasp.protocol.observer import TrialObserver
from manigrasp.protocol.result import GraspMetrics, Phase, Status
from manigrasp.protocol.sampling import Sampler
from manigrasp.sim import Scene, current_grip_force, grip_force, read_hand_contacts

CLOSE_MODES = ("synergy", "per_finger")  # `GraspParams.close_mode`
FINGER_HOLDS = ("balanced", "fingertips", "joints", "floor")  # `GraspParams.finger_hold`

Trajectory = Callable[[float], tuple[np.ndarray, np.ndarray]]
"""A set-point as a function of the time since its phase began [s]: (TCP pose (4, 4), twist (6,)), world."""


@dataclass(frozen=True)
class GraspParams:
    """How a grasp is executed and judged (shared by every protocol).

    Attributes:
        pregrasp_offset: the open hand starts this far back along the approach axis [m].
        approach_speed: speed of the approach set-point [m/s].
        approach_settle_s: time held at the grasp pose before closing [s].
        grip_force: grip force to close to [N]; None: `grip_force_fraction` of the hand's maximum.
        grip_force_fraction: fraction of `hand.max_grip_force` used when `grip_force` is None [-].
        close_speed: synergy rate while closing on position [1/s].
        contact_force: grip force that counts as touching the object [N].
        close_settle_s: time the grip force is regulated after first contact [s].
        close_timeout_s: longest closing phase [s]; no contact by then: `no_contact`.
        translation_threshold: largest object motion relative to the hand [m].
        rotation_threshold_deg: largest object rotation relative to the hand [deg].
        min_fingers: distinct finger bodies that must touch the object at the end.
        impedance_omega: translational natural frequency of the hand's impedance [rad/s].
        impedance_omega_rot: rotational natural frequency [rad/s].
        payload_feedforward: add the object's weight as feed-forward once grasped.
        max_speed: any body faster than this means divergence [m/s].
        max_angular_speed: any body spinning faster than this means divergence [rad/s].
        control_period_s: time between control ticks [s] (rounded to whole steps) while a
            set-point moves or the grip loop runs: set-point updates and the grip-force loop
            run at this rate; MuJoCo runs the impedance (base servos) and the finger servos
            every step, so a phase that holds still has no control ticks at all.
        check_period_s: time between fault and motion checks [s] (rounded to whole steps; also
            checked at the end of every stepping call).
        regulate_grip_after_close: keep the grip-force loop running after the close phase
            (reading contacts every tick); False: the finger command is held where the loop
            left it, and the finger servos hold the grip with no Python in the loop.
        finger_hold_gain: after a dexterous hand closes, hold each finger servo that closes with the
            squeeze this many times stiffer against being pushed open, keeping the force it reached
            (`manigrasp.control.FingerHold`; default `HOLD_GAIN`, 40); 0: off [-].
        close_mode: how a dexterous hand closes: "synergy" (one command along the hand path for every finger,
            `control.GripController`: the grip force is regulated as soon as the thumb and the first fingers
            touch) or "per_finger" (each finger closes on its own until it touches the object, then the grip
            force is regulated by a common offset on the fingers that touched, `control.FingerClose`). A
            parallel-jaw hand closes with the synergy in either mode. Opt-in: it puts more fingers on the
            object and pushes it less, with no gain in success beyond noise (dexterous config, `standard` at
            10 N, seed 0, 7 objects x 10: dexopt Allegro 40 -> 40/70, Fourier 37 -> 37, Inspire 44 -> 45;
            power 19 -> 23, 53 -> 57, 54 -> 50; see `control.fingers`).
        finger_hold: how a finger with several closing servos (the Allegro's) is held after the close:
            "floor" (each servo as a finger of its own: stiff against opening, still pushing with `FLOOR` of its
            force where the object yields), "joints" (the finger's joint configuration held, no push),
            "fingertips" (in a grasp the palm does not touch, "joints" for a finger that touches the object with its
            distal phalanx only, or not at all, "floor" for one that wraps it with inner links too; "floor" for
            every finger of a grasp pressed into the palm) or "balanced" (the default since 4 Dec 2026: as
            "fingertips", and where every finger touching is so held, they press the forces that hold the object's
            weight with the least friction at the contacts the close reached, `phases.balanced_torques`; Allegro
            dexopt 238 -> 248/350 over "fingertips", `control.hold`). A finger one actuator closes (the five-finger
            hands' tendons) keeps the floor in every mode, and they are held alike under "fingertips" and
            "balanced"; see `control.hold`.
        metric_edges: edges of the linearised friction cones in the metrics.
        metric_friction_tol: tolerance of the smallest-friction-for-closure bisection [-].
        simulated_min_friction: also compute the smallest friction for closure of the simulated
            contacts (a bisection of hull computations, ~0.1-0.4 s per trial; off: NaN).
        torque_scale: length dividing torques in the metrics [m]; None: the object's radius of gyration.
    """

    RENAMED: ClassVar[dict[str, str]] = {
        "finger_hold_joints": "use finger_hold (true: joints, false: floor; the default is now balanced)"}

    pregrasp_offset: float = PREGRASP_OFFSET
    approach_speed: float = 0.10
    approach_settle_s: float = 0.1
    grip_force: float | None = None
    grip_force_fraction: float = 0.5
    close_speed: float = 2.0
    contact_force: float = 0.5
    close_settle_s: float = 0.3
    close_timeout_s: float = 2.0
    translation_threshold: float = 0.02
    rotation_threshold_deg: float = 15.0
    min_fingers: int = 2
    impedance_omega: float = 40.0
    impedance_omega_rot: float = 100.0
    payload_feedforward: bool = True
    max_speed: float = 20.0
    max_angular_speed: float = 200.0
    control_period_s: float = 0.01
    check_period_s: float = 0.02
    regulate_grip_after_close: bool = False
    finger_hold_gain: float = HOLD_GAIN
    finger_hold: str = "balanced"
    close_mode: str = "synergy"
    metric_edges: int = 8
    metric_friction_tol: float = 0.01
    simulated_min_friction: bool = False
    torque_scale: float | None = None

    def __post_init__(self) -> None:
        for name in ("approach_speed", "close_speed", "contact_force", "close_timeout_s", "translation_threshold",
                     "rotation_threshold_deg", "impedance_omega", "impedance_omega_rot", "max_speed",
                     "max_angular_speed", "control_period_s", "check_period_s"):
            if not getattr(self, name) > 0:
                raise ConfigError(f"{name} must be > 0, got {getattr(self, name)}")
        for name in ("pregrasp_offset", "approach_settle_s", "close_settle_s"):
            if not getattr(self, name) >= 0:
                raise ConfigError(f"{name} must be >= 0, got {getattr(self, name)}")
        if self.grip_force is not None and not self.grip_force > 0:
            raise ConfigError(f"grip_force must be > 0 or None, got {self.grip_force}")
        if not 0 < self.grip_force_fraction <= 1:
            raise ConfigError(f"grip_force_fraction must be in (0, 1], got {self.grip_force_fraction}")
        if self.min_fingers < 0:
            raise ConfigError(f"min_fingers must be >= 0, got {self.min_fingers}")
        if self.metric_edges < 4 or self.metric_edges % 2 or not self.metric_friction_tol > 0:
            raise ConfigError("metric_edges must be even and >= 4, metric_friction_tol > 0")
        if not (self.finger_hold_gain == 0 or self.finger_hold_gain >= 1):
            raise ConfigError(f"finger_hold_gain must be 0 (off) or >= 1, got {self.finger_hold_gain}")
        if self.finger_hold not in FINGER_HOLDS:
            raise ConfigError(f"finger_hold must be one of {', '.join(FINGER_HOLDS)}, got {self.finger_hold!r}")
        if self.close_mode not in CLOSE_MODES:
            raise ConfigError(f"close_mode must be one of {', '.join(CLOSE_MODES)}, got {self.close_mode!r}")
        if self.torque_scale is not None and not self.torque_scale > 0:
            raise ConfigError(f"torque_scale must be > 0 or None, got {self.torque_scale}")


class Abort(Exception):
    """Ends a trial with `status` (and `detail`)."""

    def __init__(self, status: Status, detail: str = "") -> None:
        super().__init__(f"{status.value}: {detail}")
        self.status, self.detail = status, detail


def object_in_hand(scene: Scene) -> np.ndarray:
    """(4, 4) the object's pose in the TCP frame of `scene` now."""
    body = scene.object_body
    obj = np.eye(4)
    obj[:3, :3], obj[:3, 3] = scene.data.xmat[body].reshape(3, 3), scene.data.xpos[body]
    return relative_pose(scene.tcp_pose(), obj)


class TrialRun:
    """The state of one trial: controllers, step count, faults, motion of the object in the hand.

    Args:
        scene: the compiled scene (already reset for this trial).
        params: execution parameters.
        deadline: `clock()` value after which the trial is a `timeout`, or None.
        clock: the monotonic clock the deadline refers to.
        observer: called at phase changes and sample times, or None.
        sampler: the stepper that stops at the observer's sample times (shared with
            settling); default: a new one for `observer`.
    """

    def __init__(self, scene: Scene, params: GraspParams, deadline: float | None,
                 clock: Callable[[], float] = time.monotonic, observer: TrialObserver | None = None,
                 sampler: Sampler | None = None) -> None:
        self.scene, self.params, self.deadline, self.clock = scene, params, deadline, clock
        self.observer = observer
        self.sampler = sampler or Sampler(scene, observer)
        self.dt = float(scene.model.opt.timestep)
        self.chunk = max(1, round(params.control_period_s / self.dt))
        self.check_chunk = max(1, round(params.check_period_s / self.dt))
        self.next_check = self.check_chunk
        self.steps = 0
        self.time0 = 0.0  # simulated time before this run's own steps (settling) [s]
        self.last_phase: Phase | str = ""  # the last top-level phase passed ("" before any)
        self.stopped_in: tuple[Phase, str] | None = None  # (phase, detail) in progress when the trial stopped
        self._depth = 0  # phases in progress (nested: the hold inside the lift)
        self.impedance = self._impedance()
        self.grip: GripController | FingerClose | None = None
        self.in_hand: np.ndarray | None = None  # object-in-TCP pose after closing (the reference)
        self.watch: tuple[np.ndarray, Status, str] | None = None
        self.max_translation, self.max_rotation = math.nan, math.nan
        self.grip_force_n = math.nan
        self.simulated = GraspMetrics()
        self.torque_scale = params.torque_scale or radius_of_gyration(scene)
        self.joints: np.ndarray | None = None  # (2, n_act) the grasp's own hand path, None: the hand's
        self.pregrasp_offset = params.pregrasp_offset  # [m] where the open hand starts, back along the approach
        self.approach_note = ""  # how far short of the grasp pose the last approach stopped, and against what

    def use_grasp(self, grasp: Grasp) -> None:
        """Execute `grasp` (checked by `check_grasp`): its hand path (`Grasp.joints`, else the hand's own)
        from the next `reset` on, and its pre-grasp offset (else the protocol's)."""
        self.joints = None if grasp.joints is None else np.array(grasp.joints, dtype=float)
        if grasp.pregrasp_offset is not None:
            self.pregrasp_offset = float(grasp.pregrasp_offset)

    @property
    def sim_time(self) -> float:
        """Simulated time of the trial [s]: settling (if the trial settled) plus its own steps."""
        return self.time0 + self.steps * self.dt

    def reset(self, mount: np.ndarray, object_pose: np.ndarray, synergy: float) -> None:
        """Reset the scene (hand open at `mount` on the grasp's hand path at `synergy`, object at
        `object_pose`) and the controllers.

        The impedance gains are designed from the hand's inertia at the reset state, so a trial
        does not depend on what the scene did before it. The scene's clock keeps running across
        the resets of one trial (`sim_time`), so observers see one time line.
        """
        if self.joints is None:
            self.scene.set_hand_path()
        else:
            self.scene.set_hand_path(self.joints[0], self.joints[1])
        self.scene.reset(mount=mount, object_pose=object_pose, synergy=synergy)
        self.scene.data.time = self.sim_time
        self.impedance = self._impedance()
        self.impedance.engage()
        self.impedance.set_target(mount)
        self.grip, self.in_hand, self.watch = None, None, None

    def _impedance(self) -> NativeImpedance:
        p = self.params
        return NativeImpedance(self.scene.base, default_gains(self.scene.base, p.impedance_omega,
                                                              p.impedance_omega_rot))

    @contextmanager
    def phase(self, phase: Phase, detail: str = "", *, watch: Status | None = None,
              reference: np.ndarray | None = None, announce: bool = True) -> Iterator[None]:
        """``with run.phase(Phase.LIFT): ...``: one phase of the trial.

        It tells the observer that the phase begins (unless not `announce`), watches the object in
        the hand while it runs, and records it: leaving a top-level phase normally makes it
        `last_phase` (a phase nested in another, such as the hold inside the lift, counts through
        the enclosing one); leaving on an exception keeps the innermost phase in `stopped_in`.

        Args:
            phase: the phase.
            detail: e.g. the perturbation direction ("+x"): told to the observer, and it names the watch.
            watch: the object moving past the thresholds in the hand relative to `reference` (default:
                its pose in the hand as the phase begins) ends the trial with this status; None: the
                enclosing phase's watch goes on (named by `detail` if given). The watch in force before
                is back when the phase ends.
            announce: tell the observer (False: a phase whose beginning it does not see).
        """
        saved = self.watch
        if watch is not None:
            self.watch = (self.object_in_hand() if reference is None else reference, watch, detail or phase.value)
        elif saved is not None and detail:
            self.watch = (saved[0], saved[1], detail)
        if announce and self.observer is not None:
            self.observer.on_phase(self.scene, phase, detail)
        self._depth += 1
        try:
            yield
        except BaseException:
            self.stopped_in = self.stopped_in or (phase, detail)
            raise
        finally:
            self._depth -= 1
            self.watch = saved
        if self._depth == 0:
            self.last_phase = phase

    # ------------------------------------------------------------ stepping
    def step(self, n: int, trajectory: Trajectory | None = None) -> None:
        """Advance `n` steps: control ticks while something moves, checks every check period and at the end.

        While a `trajectory` or the grip loop is active, a control tick every control period
        sets the set-point from `trajectory` (evaluated at the middle of the coming period,
        time counted from this call) and updates the grip loop. The steps between ticks and
        checks run in one call into MuJoCo. `check` runs every check period of the trial's
        steps and once at the end of the call, so every motion is judged under its own phase.
        """
        done = 0
        while done < n:
            active = trajectory is not None or self.grip is not None
            k = min(n - done, self.next_check - self.steps, self.chunk if active else n)
            if trajectory is not None:
                pose, twist = trajectory((done + 0.5 * (k + 1)) * self.dt)
                self.impedance.track(pose, twist)
            if isinstance(self.grip, FingerClose):
                self._finger_tick(self.grip)
            elif self.grip is not None:
                scene = self.scene
                force = current_grip_force(scene)
                scene.set_synergy(self.grip.update(force, self.chunk * self.dt, scene.hand_synergy(),
                                                   scene.closing_reach()))
            self.sampler.advance(k)
            self.steps += k
            done += k
            if self.steps >= self.next_check:
                self.next_check += self.check_chunk
                self.check()
        if self.steps != self.next_check - self.check_chunk:
            self.check()

    def _finger_tick(self, grip: FingerClose) -> None:
        """One control tick of a per-finger close: each finger's normal force on the object and the grip force
        in, the hand's actuator commands out."""
        scene = self.scene
        contacts = read_hand_contacts(scene)
        own = contacts.finger >= 0
        forces = np.bincount(contacts.finger[own], weights=np.clip(contacts.normal_force[own], 0.0, None),
                             minlength=grip.n_fingers)[:grip.n_fingers]
        scene.data.ctrl[scene.hand_actuators] = grip.update(
            forces, grip_force(contacts), scene.data.actuator_length[scene.hand_actuators], self.chunk * self.dt)

    def hold_for(self, seconds: float) -> None:
        """Step for `seconds` [s] with the current set-points."""
        self.step(self.n_steps(seconds))

    def n_steps(self, seconds: float) -> int:
        """Steps in `seconds` [s] (rounded up)."""
        return int(math.ceil(seconds / self.dt - 1e-9))

    def check(self) -> None:
        """Raise `Abort` on a fault, a blown deadline, or too much motion of the object in the hand."""
        scene, data = self.scene, self.scene.data
        # A sum is finite only if every term is (an overflow to inf is a divergence too).
        if not math.isfinite(float(data.qpos.sum() + data.qvel.sum() + data.qacc.sum())):
            raise Abort(Status.UNSTABLE, "non-finite simulation state (NaN or inf)")
        if data.warning.number.any():
            warnings = scene.warnings()
            raise Abort(Status.UNSTABLE, "MuJoCo warning: " + ", ".join(f"{k} x{v}" for k, v in warnings.items()))
        cvel = np.abs(data.cvel)
        speed, spin = float(cvel[:, 3:].max()), float(cvel[:, :3].max())
        if speed > self.params.max_speed or spin > self.params.max_angular_speed:
            raise Abort(Status.UNSTABLE, f"divergence: a body moves at {speed:.3g} m/s, {spin:.3g} rad/s")
        if self.deadline is not None and self.clock() > self.deadline:
            passed = str(self.last_phase) or "start"
            raise Abort(Status.TIMEOUT, f"wall-clock deadline exceeded in phase after {passed!r}")
        if self.in_hand is not None:
            self._track()

    def object_in_hand(self) -> np.ndarray:
        """(4, 4) object pose in the TCP frame (`object_in_hand`)."""
        return object_in_hand(self.scene)

    def _track(self) -> None:
        current = self.object_in_hand()
        shift, angle = pose_distance(self.in_hand, current)
        self.max_translation = max(shift, 0.0 if math.isnan(self.max_translation) else self.max_translation)
        self.max_rotation = max(angle, 0.0 if math.isnan(self.max_rotation) else self.max_rotation)
        if self.watch is not None:
            reference, status, detail = self.watch
            shift, angle = pose_distance(reference, current)
            p = self.params
            if shift > p.translation_threshold or angle > p.rotation_threshold_deg:
                raise Abort(status, f"{detail}: object moved {100 * shift:.1f} cm / {angle:.1f} deg in the hand")

    # ------------------------------------------------------------- helpers
    def fingers_touching(self) -> tuple[str, ...]:
        """Names of the finger bodies pushing on the object now."""
        fingers = read_hand_contacts(self.scene).fingers_touching
        return tuple(self.scene.hand.finger_bodies[i] for i in fingers)

    def hold_target(self, pose: np.ndarray, feedforward: np.ndarray | None = None) -> None:
        """Hold the TCP still at `pose` with `feedforward` (6,) (None: keep the current feed-forward)."""
        self.impedance.set_target(pose, feedforward=self.impedance.feedforward if feedforward is None
                                  else feedforward)

    def payload(self) -> np.ndarray:
        """(6,) world wrench holding the object's weight (zero when not enabled)."""
        out = np.zeros(6)
        if self.params.payload_feedforward:
            out[:3] = -self.scene.object_mass() * self.scene.model.opt.gravity
        return out
