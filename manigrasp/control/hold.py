"""Hold a closed grasp: each finger servo stiff against being pushed open, still pushing where the object yields;
given the fingers (opt-in), a finger with several closing joints keeps its joint configuration instead.

The dexterous hands close with soft position servos (a blocked finger pushes with kp (u - L), kp small) so that
the grip force can be regulated through the synergy (`GripController`). Left that way after closing, every
finger is a soft spring wound well past its contact: under a load (the lift, a push) the fingers and the thumb
trade the object between them at almost constant forces, the fingers curl on, and the object rolls along them
and out of the palm (`slipped_lift`, the main failure of `manigrasp bench dexterous`; a can grasped by hand
creeps 12-20 mm in the five-finger hands under the standard protocol).

A plain stiff hold (each servo `gain` times stiffer, its command just past where the finger stands so that it
keeps its force f) stops the creep but is fragile: its pre-load spans only f / (gain kp) of joint travel
(0.3 N m at 20 N m/rad: 0.015 rad, under a millimetre at a fingertip), so the millimetre an object settles in
its contacts when the lift starts unloads the fingers and the grip falls to nothing. On the `power` planner's
grasps it lost successes (3 objects x 10 grasps, `standard`, 10 N: allegro_right 4/30 held vs 10/30 not held,
inspire_right 7 vs 10).

`FingerHold.engage` therefore holds each servo that closes with the squeeze one-sided:

- stiffness kp' = `gain` kp, command just past where the finger stands, u = L + f / kp', so it keeps the force
  f it had when the grip was regulated (the target grip force);
- its force kept within [f_min, f_max] in the closing direction (MuJoCo's actuator force range; f_max the
  servo's own limit), f_min = `FLOOR` f: pushed open, the finger resists at kp' up
  to its limit; where the object moves away, the finger follows it with at least f_min instead of letting go.
  The floor is a fraction of f: fingers following at their full force overpower a thumb already near its limit
  (a hand-placed can then creeps 11 mm in the Inspire hand); at `FLOOR` the squeeze stays on the object and the
  can creeps under 2 mm in every hand (`benchmarks/bench_grip_hold.py`).

The floor suits a finger that closes along one path: a tendon or linkage that one actuator drives (each finger of the
five-finger hands), which follows the object along the path it closed on. A finger with several servoed joints that
close (the Allegro's fingers: three, its thumb: two) named in `engage`'s `joint_fingers` has its joint configuration
held instead (floor 0: stiff against opening, pushing nothing where the object yields). Which fingers, the protocols'
`finger_hold` says (`protocol.phases.joint_held_fingers`): by default ("balanced", and "fingertips") those of a grasp
the palm does not touch that touch the object with their distal phalanx only (or not at all). Under "balanced" (the
default since 4 Dec 2026), where every finger touching is so held, `engage` is given the force each of their servos
should press (`forces`, `protocol.phases.balanced_torques`): the least-friction contact forces that hold the object's
weight at the contacts the close reached (grasp force optimisation, `grasp.forces.balanced_forces`), at the grip the
close regulated. Why: the Allegro's close leaves the squeeze's contacts on their friction cones (a replayed banana
pinch, `benchmarks/diagnose_dexterous.py`: thumb and middle finger at cone 1.00 with 34 N pressed on the 66 g banana,
which turned out of the grip during the lift), so the heavy objects had no friction to spare for their weight.
Measured (allegro_right, dexopt, the dexterous config's 7 objects x 10, `standard` at 10 N, seeds 0-4, paired:
`manigrasp bench` with `protocol.params.finger_hold=MODE`), "fingertips" -> "balanced": 238 -> 248/350 (held only with
it 12, only without 2, exact McNemar p = 0.013); sugar box 22 -> 27/50, mustard bottle 6 -> 10/50, banana 20 -> 21/50,
the rest within 1. power seed 0: 22 -> 22/70 (1 status changed). The five-finger hands are held alike in both modes (no
finger of theirs has several servos; Inspire dexopt seed 0: 53/70 under both, trial for trial). Holding every finger
that way ("joints") trades planners: it helps fingertip grasps and costs wraps (allegro_right, the dexterous config's 7
objects x 10, `standard` at 10 N, seed 0, floor on every joint -> held per finger: dexopt 32 -> 37/70, power 19 ->
11/70, the power wraps of the soup can 8 -> 1/10, pressed into the palm at 37 N; a floor of 0.2 on such fingers: 35 and
14/70); "fingertips" keeps both (4 Dec 2026, the dexterous config's 7 objects x 10 on the Allegro, `standard` at 10 N,
paired seeds, floor -> fingertips: dexopt seed 0 41 -> 50/70, seed 1 47 -> 50/70, as "joints"; power seed 0 24 -> 22/70,
where "joints" gave 15). For fingertip grasps: with a floor on each joint, a finger the object moves away from keeps
pushing on every joint in a ratio that no longer matches the contact it held, so it curls on along the object and rolls
it. Measured on the Allegro's dexopt grasps (tomato soup can, potted meat can, mug, banana x 5, `standard` at 10 N;
replayed with an observer, from the start of the lift to the first perturbation): with the floor on every joint, 12/20
succeeded; the 5 that dropped in the perturbations had turned 8.7 deg in the hand (median; successes 1.3 deg), 4.8 deg
of it carried by the fingers' own motion (the rotation of their contact points in the hand; the rest slip, largest 4.5
mm), their fingers curled on by up to 0.12 rad (median of the largest joint motion; successes 0.02 rad;
`benchmarks/bench_grip_hold.py --run`). Held per finger: 15/20, largest joint motion 0.008 rad in the successes, 0.028
in the 2 drops; two mug grasps that dropped turn 2.2 and 2.3 deg instead of 8.7 and 9.2 deg. Not the cause there: the
thumb at its 0.7 N m limit (1.4 N m in a replay: 12/20), the grip level (7 or 8 N: 13, 12/20), a slower lift (0.03 m/s:
11/20), the hold gain (10 or 200 with the floor: 12, 11/20; 10, 20, 80 held per finger: 16, 16, 15/20); without the hold
6/20, with the full force as the floor 4/20 (fingers that follow at full force roll the object further). The five-finger
hands' tendon fingers keep the floor: without it, inspire_right's dexopt grasps of the same objects held 14/20, with it
17/20.

The closing direction of each actuator is given to `engage` (the closed row of the hand's path minus its open
row); actuators that do not move with the squeeze (finger spread, thumb rotation: they hold the pre-shape and
are stiff already) are left as they are. `release` restores the model's gains and force ranges (the scene's
model is reused by the next trial).

Only actuators that are position servos (bias = -kp L - kv dL/dt, MuJoCo's ``position``) are changed;
anything else (motors, a user's custom actuators) is left alone.
"""

from __future__ import annotations

from collections.abc import Collection

import mujoco
import numpy as np

from manigrasp.errors import ConfigError
from manigrasp.sim.scene import position_servos

# Stiffness of the held grasp relative to the closing servo's [-] (the protocols' default `finger_hold_gain`): the
# robosuite hands' 0.5 N m/rad tendons hold at 20 N m/rad, the Allegro's 1 N m/rad joints at 40 (a finger pushed
# open 0.01 rad then gains 0.2-0.4 N m of its 0.6-0.9 N m).
HOLD_GAIN = 40.0
# Force floor of a held servo in its closing direction, as a fraction of the force it had when engaged [-].
FLOOR = 0.4


class FingerHold:
    """Hold (and release) the position servos among `actuators` of `model`.

    Args:
        model: the scene's model (its gains and force ranges are edited in place by `engage`, restored by
            `release`).
        actuators: ids of the hand's actuators.
        gain: stiffness multiple of the held grasp [-] (>= 1).
        fingers: (n,) the finger each of `actuators` moves (e.g. `Scene.actuator_fingers`; -1: none or several);
            `engage` may hold the servos of a finger with several that close without a floor (see the module
            docstring). None: every actuator its own finger (each held servo gets the floor).
    """

    def __init__(self, model: mujoco.MjModel, actuators: np.ndarray, gain: float = HOLD_GAIN,
                 fingers: np.ndarray | None = None) -> None:
        if not gain >= 1.0:
            raise ConfigError(f"the hold gain must be >= 1, got {gain}")
        self.model, self.gain = model, float(gain)
        ids = np.asarray(actuators, dtype=int)
        fingers = np.full(len(ids), -1) if fingers is None else np.asarray(fingers, dtype=int)
        if fingers.shape != ids.shape:
            raise ConfigError(f"fingers must be ({len(ids)},), got shape {fingers.shape}")
        servo = position_servos(model, ids)
        self.actuators, self.servo = ids, servo
        self.ids = ids[servo]
        self.fingers = fingers[servo]
        self.kp = model.actuator_gainprm[self.ids, 0].copy()
        self.kv = -model.actuator_biasprm[self.ids, 2].copy()
        self.forcerange = model.actuator_forcerange[self.ids].copy()
        self.forcelimited = model.actuator_forcelimited[self.ids].copy()
        self.held = np.zeros(0, dtype=int)
        self.engaged = False

    def engage(self, data: mujoco.MjData, closing: np.ndarray, joint_fingers: Collection[int] = (),
               forces: np.ndarray | None = None) -> np.ndarray:
        """Hold the servos that close with the squeeze; returns the new commands of all servos (`ids` order).

        Args:
            data: the scene's data, with the grasp closed and its grip force regulated.
            closing: (n,) command change from open to closed of each of the `actuators` given at construction
                (its sign is the closing direction; 0: the actuator does not take part in the squeeze and is
                left alone).
            joint_fingers: the fingers (indices as in `fingers`) to hold in their joint configuration if
                several of their servos close.
            forces: (n,) force [N or N m] each of the `actuators` should press with instead of the one it had
                (NaN: as it had; e.g. `protocol.phases.balanced_torques`): its command becomes L + force / kp (its
                held stiffness if it closes with the squeeze, else its own), the force clipped to the servo's own
                force range, which it gets back whole (both ways: a joint-held finger may press in any direction).

        Each held servo keeps its current spring force f = kp (u - L) (clamped to its force range): its command
        becomes u' = L + f / kp' (clamped to the control range), its stiffness kp' = gain kp, its damping
        sqrt(gain) kv (same damping ratio), and its force range [f_min, f_max] in the closing direction,
        f_min = 0 if its finger is one of `joint_fingers` with several held servos (the finger's joint
        configuration is held), else `FLOOR` f.
        """
        m = self.model
        closing = np.asarray(closing, dtype=float)
        if closing.shape != self.actuators.shape or not np.all(np.isfinite(closing)):
            raise ConfigError(f"closing must be ({len(self.actuators)},) finite, got shape {closing.shape}")
        sign = np.sign(closing[self.servo])
        take = sign != 0
        ids, kp0, kv0, sign = self.ids[take], self.kp[take], self.kv[take], sign[take]
        fingers = self.fingers[take]
        shared = ((fingers >= 0) & (np.sum(fingers[:, None] == fingers[None, :], axis=1) > 1)
                  & np.isin(fingers, np.fromiter(joint_fingers, int)))
        low, high = self.forcerange[take, 0], self.forcerange[take, 1]
        limited = self.forcelimited[take].astype(bool)
        length = data.actuator_length[ids]
        spring = kp0 * (data.ctrl[ids] - length)
        spring = np.where(limited, np.clip(spring, low, high), spring)
        push = np.maximum(sign * spring, 0.0)  # force in the closing direction [N or N m]
        limit = np.where(limited, np.where(sign > 0, high, -low), np.inf)
        floor = np.where(shared, 0.0, FLOOR) * push
        kp = self.gain * kp0
        m.actuator_gainprm[ids, 0] = kp
        m.actuator_biasprm[ids, 1] = -kp
        m.actuator_biasprm[ids, 2] = -np.sqrt(self.gain) * kv0
        m.actuator_forcelimited[ids] = 1
        big = np.where(np.isfinite(limit), limit, np.finfo(float).max)
        m.actuator_forcerange[ids] = np.where((sign > 0)[:, None], np.column_stack([floor, big]),
                                              np.column_stack([-big, -floor]))
        data.ctrl[ids] = _within_ctrlrange(m, ids, length + sign * push / kp)
        if forces is not None:
            self._press(data, np.asarray(forces, dtype=float))
        self.held = ids
        self.engaged = True
        return data.ctrl[self.ids].copy()

    def _press(self, data: mujoco.MjData, forces: np.ndarray) -> None:
        """`engage`'s `forces`: each servo given a finite force presses it, within its own force range."""
        if forces.shape != self.actuators.shape:
            raise ConfigError(f"forces must be ({len(self.actuators)},), got shape {forces.shape}")
        m, given = self.model, np.isfinite(forces[self.servo])
        ids, force = self.ids[given], forces[self.servo][given]
        limited = self.forcelimited[given].astype(bool)
        low = np.where(limited, self.forcerange[given, 0], -np.inf)
        high = np.where(limited, self.forcerange[given, 1], np.inf)
        force = np.clip(force, low, high)
        data.ctrl[ids] = _within_ctrlrange(m, ids, data.actuator_length[ids] + force / m.actuator_gainprm[ids, 0])
        m.actuator_forcelimited[ids] = self.forcelimited[given]
        m.actuator_forcerange[ids] = self.forcerange[given]

    def release(self) -> None:
        """Restore the closing gains and force ranges (idempotent)."""
        m, ids = self.model, self.ids
        m.actuator_gainprm[ids, 0] = self.kp
        m.actuator_biasprm[ids, 1] = -self.kp
        m.actuator_biasprm[ids, 2] = -self.kv
        m.actuator_forcerange[ids] = self.forcerange
        m.actuator_forcelimited[ids] = self.forcelimited
        self.held = np.zeros(0, dtype=int)
        self.engaged = False


def _within_ctrlrange(model: mujoco.MjModel, ids: np.ndarray, ctrl: np.ndarray) -> np.ndarray:
    """Commands `ctrl` of actuators `ids`, each clamped to its control range where it has one."""
    limited = model.actuator_ctrllimited[ids].astype(bool)
    return np.where(limited, np.clip(ctrl, model.actuator_ctrlrange[ids, 0], model.actuator_ctrlrange[ids, 1]), ctrl)
