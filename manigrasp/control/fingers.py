"""A guarded close per finger for dexterous hands (`GraspParams.close_mode` ``per_finger``).

The synergy close (`GripController`) drives every finger with one command along the hand path and stops
advancing as soon as the grip force (thumb against the rest, `manigrasp.sim.grip_force`) reaches its target.
On a five-finger hand that happens when the thumb and the first one or two fingers touch; the others stay
wherever the common command left them, short of the object (every planned finger touched at the end of the
close in 1 of 25 Fourier and 3 of 24 Inspire dexopt grasps, `benchmarks/diagnose_dexterous.py --versus-plan`), and
the fingers that touched first, their soft servos wound up to the common command, push the object along the
table before the others arrive.

`FingerClose` closes each finger on its own:

1. *Closing*: each finger (the actuators `Scene.actuator_fingers` gives it) follows its own part of the hand
   path, its synergy command ramping at `close_speed` up to max(where it is + `lead`, where it is + the command
   lead that brings its servo to its force limit), as the synergy close does for the hand.
2. *Touched*: once the finger's own normal force on the object reaches `touch_force`, it stops advancing:
   each of its actuators is commanded just past where it stands (its length plus `PRELOAD` of the command
   lead to its force limit, a tenth of its strongest push), so it rests on the object without pushing it away
   while the others continue. A touched finger that loses the object while others still close closes again.
3. *Stopped*: a finger that does not move on for `STALL_S` (blocked by the table, the palm or another finger)
   or reaches the end of its path without touching stops where it is (commanded just past it, as in 2).
4. *Squeeze*: once no finger is closing (or `wait_s` after the thumb and a finger first gripped: a finger
   that is still closing then, e.g. one passing under the object, closes on and joins when it touches), the grip
   force is regulated to the target by one offset o of the
   synergy added to every touched finger's command (each actuator: its length at the touch + its preload + o
   along its span, the command kept within the path): o = (kp e + ki integral e dt) / k from 0, e the grip
   force error [N], k = full_force / (1 - the touched actuators' mean synergy at the touch), the estimate of
   `GripController` (the grip grows linearly to `Hand.max_grip_force` over the rest of the path); o is kept
   within [-preload, 1] (the integral freezes at the bounds). (A k from the command leads to the servos' force
   limits, full_force / their mean, made the loop oscillate on the Allegro's dexopt paths, whose squeeze rows
   move some joints by a few hundredths of a radian: leads of 3-30 of the synergy.)

Each finger's servo therefore pushes on the object with (preload + o) of its own travel from where it touched:
the squeeze is shared among all the fingers that reached the object, not among the first to arrive.

Fully actuated fingers (the Allegro's: three closing servos per finger, two for the thumb) are one finger each:
a contact on any link of the finger stops all its servos, each just past its own position; a finger of the
five-finger hands is one tendon actuator.

Measured (the dexterous config under `standard` at 10 N, seed 0, 7 objects x 10 per hand and planner; the run's
stored grasps replayed with ``close_mode`` changed, `benchmarks/diagnose_dexterous.py RUN --with
close_mode=per_finger`, which gives what ``manigrasp bench`` with the override gives: 20/20 trials identical on a
check; the mug's dexopt grasps from a run with ``trial_timeout_s=900``, its planning having overrun 120 s on the
loaded machine), synergy -> per_finger:

- success, dexopt: allegro_right 40 -> 40/70, fourier_right 37 -> 37, inspire_right 44 -> 45; power: 19 -> 23,
  53 -> 57, 54 -> 50. No change is beyond noise: the trials that change go both ways (lost + gained, dexopt:
  Allegro 3 + 3, Fourier 9 + 9, Inspire 2 + 3; power: 5 + 9, 4 + 8, 6 + 2; exact McNemar p >= 0.29);
- the close itself, dexopt (trials that reached the end of the close): every finger on the object (>= 0.1 N)
  Fourier 1/64 -> 16/63, Inspire 20/67 -> 37/66, Allegro 61/69 -> 58/67; the object pushed over 5 mm on the
  table by the close: Fourier 27/64 -> 15/63, Inspire 12/67 -> 12/66, Allegro 29/69 -> 25/67.

So the close has fewer of the defects the planner's diagnosis blamed (`diagnose_dexterous --versus-plan`), and
the successes do not follow. Of the 14 dexopt successes it loses, 9 drop in the perturbations and 5 slip in
the lift, mostly on the heavier objects (sugar box, mustard bottle, mug: 9; 5 of these 9 the synergy close held
with 2-3 fingers on, this one closes with 4-5); it wins 15 (the banana and the potted meat can: 9). In the two lost
grasps traced (Fourier, mustard 0004 and tomato soup can 0000) the thumb's servo pushed 0.25-0.42 N m at the
start of the lift against 0.46-0.86 N m after the synergy close for the same grip force, and `FingerHold` holds
what the close reached. Opt-in for that reason. Not better either (Fourier dexopt, tomato soup
can + mustard bottle x 10, against 12/20 with the synergy): `PRELOAD` 0.3 10/20, 0.1 9/20.
Nor does resting the fingers still closing when the close ends just past where they stand (instead of leaving
their commands run ahead, as the synergy close leaves the fingers that have not touched): Fourier dexopt, all
7 objects x 10, 36/70 against 37/70.
Rejected while building it: a stall check on the clipped finger position (a finger still short of its open
command never counted as moving and stopped at once), a squeeze that waited for every finger (a finger passing
under the object closed on until the close's timeout: `no_contact`), a feed-forward offset target / k at the
start of the squeeze (11.4 N on a 10 N target at once).
"""

from __future__ import annotations

import numpy as np

from manigrasp.control.hybrid import STALL_S, STALL_SYNERGY, ForcePI
from manigrasp.errors import ConfigError

PRELOAD = 0.1  # [-] a touched finger's command lead past where it stands, as a fraction of its lead to the force limit
CLOSED = 0.995  # [-] a finger this far along its path has reached its end
CLOSING, TOUCHED, STOPPED = 0, 1, 2


class FingerClose:
    """Per-finger guarded close of a dexterous hand, then grip-force regulation by a common offset.

    Args:
        open_ctrl, closed_ctrl: (n,) the hand path's rows (commands at synergy 0 and 1) of the hand actuators.
        fingers: (n,) the finger each actuator moves (`Scene.actuator_fingers`; -1: none or several: such an
            actuator, and one whose open and closed commands are equal, keeps its open command).
        leads: (n,) each actuator's command lead to its servo's force limit in synergy units, f_max / (kp |span|)
            (`Scene.actuator_leads`; NaN: not a force-limited position servo, `lead` used instead).
        n_fingers: number of fingers (`len(hand.finger_bodies)`); finger 0 is the thumb.
        target_force: grip force to hold [N].
        full_force: grip force of the hand's saturated servos [N] (`Hand.max_grip_force`).
        close_speed: synergy rate of a closing finger's command [1/s].
        contact_force: grip force that counts as a grip (the `mode` turns to "force") [N].
        touch_force: a finger's own normal force on the object that counts as its touch [N].
        bandwidth, kp: integral gain [1/s] and proportional gain [-] of the force loop, normalised by k.
        lead: how far a closing finger's command may at least run ahead of it [-].
        wait_s: the squeeze starts at the latest this long after the grip force first reached `contact_force`
            (fingers still closing then close on, and join the squeeze when they touch) [s].
    """

    def __init__(self, open_ctrl: np.ndarray, closed_ctrl: np.ndarray, fingers: np.ndarray, leads: np.ndarray,
                 n_fingers: int, target_force: float, full_force: float, close_speed: float = 2.0,
                 contact_force: float = 0.5, touch_force: float = 0.2, bandwidth: float = 10.0, kp: float = 0.1,
                 lead: float = 0.1, wait_s: float = 0.5) -> None:
        if not 0 < target_force <= full_force or close_speed <= 0 or contact_force <= 0 or touch_force <= 0:
            raise ConfigError("need 0 < target_force <= full_force, close_speed, contact_force and touch_force > 0")
        self.open = np.asarray(open_ctrl, float)
        self.span = np.asarray(closed_ctrl, float) - self.open
        self.fingers = np.asarray(fingers, int)
        n = len(self.open)
        if self.span.shape != (n,) or self.fingers.shape != (n,) or np.shape(leads) != (n,):
            raise ConfigError(f"open_ctrl, closed_ctrl, fingers and leads must all be ({n},)")
        self.moving = (np.abs(self.span) > 1e-12) & (self.fingers >= 0) & (self.fingers < n_fingers)
        leads = np.asarray(leads, float)
        self.leads = np.where(np.isfinite(leads) & (leads > 0), leads, lead)
        self.n_fingers = n_fingers
        self.has = np.array([np.any(self.moving & (self.fingers == f)) for f in range(n_fingers)])
        self.target_force, self.full_force, self.close_speed = target_force, full_force, close_speed
        self.contact_force, self.touch_force = contact_force, touch_force
        self.bandwidth, self.kp, self.lead, self.wait_s = bandwidth, kp, lead, wait_s
        self.reset()

    def reset(self, synergy: float = 0.0) -> None:
        """Start a new closing with every finger's command at `synergy` (0 = open)."""
        self.command = np.full(self.n_fingers, float(synergy))  # each finger's synergy command while closing
        self.state = np.where(self.has, CLOSING, STOPPED)
        self.touched_ever = np.zeros(self.n_fingers, bool)
        self.base = np.full(len(self.open), np.nan)  # each actuator's synergy where its finger came to rest
        self.offset = 0.0
        self.squeezing = False
        self.mode = "position"
        self.pi = ForcePI(self.kp, self.bandwidth, np.inf)
        self._furthest = np.full(self.n_fingers, -np.inf)
        self._still_s = np.zeros(self.n_fingers)
        self._saturated_s = 0.0
        self._gripped_s = 0.0
        self._peak = 0.0
        self.ctrl = self.open + float(synergy) * self.span

    @property
    def peak_force(self) -> float:
        """The largest grip force [N] measured while squeezing (0 before)."""
        return float(self._peak)

    @property
    def stalled(self) -> bool:
        """True while squeezing without a grip (no touched thumb against a touched finger) whose offset has been at
        its bound for `STALL_S`, or with no finger touched at all: the close cannot grip."""
        return self.mode == "position" and self.squeezing and (
            self._saturated_s >= STALL_S or not np.any(self.state == TOUCHED))

    def finger_positions(self, synergies: np.ndarray) -> np.ndarray:
        """(n_fingers,) mean synergy of each finger's moving actuators (NaN for a finger with none)."""
        out = np.full(self.n_fingers, np.nan)
        for f in np.flatnonzero(self.has):
            out[f] = float(np.mean(synergies[self.moving & (self.fingers == f)]))
        return out

    def update(self, finger_force: np.ndarray, grip_force: float, length: np.ndarray, dt: float) -> np.ndarray:
        """(n,) new actuator commands given each finger's normal force on the object `finger_force`
        (n_fingers,) [N], the `grip_force` [N] and the actuators' `length` (n,) (their transmissions' positions,
        `data.actuator_length`), after a step `dt` [s]."""
        if dt <= 0:
            raise ValueError(f"dt must be > 0, got {dt}")
        finger_force = np.asarray(finger_force, float)
        safe = np.where(self.moving, self.span, 1.0)
        raw = (np.asarray(length, float) - self.open) / safe
        synergy = np.clip(raw, 0.0, 1.0)
        where = self.finger_positions(synergy)
        moving_to = self.finger_positions(raw)  # unclipped: a finger still short of its open command moves too
        touch = finger_force >= self.touch_force
        for f in np.flatnonzero(self.has):
            acts = self.moving & (self.fingers == f)
            if self.state[f] == CLOSING:
                if touch[f]:
                    self._rest(f, acts, synergy, TOUCHED)
                    continue
                moved = moving_to[f] > self._furthest[f] + STALL_SYNERGY
                self._furthest[f] = moving_to[f] if moved else self._furthest[f]
                self._still_s[f] = 0.0 if moved else self._still_s[f] + dt
                if where[f] >= CLOSED or self._still_s[f] >= STALL_S:
                    self._rest(f, acts, synergy, STOPPED)
                    continue
                reach = float(np.min(synergy[acts] + self.leads[acts]))
                ceiling = max(where[f] + self.lead, reach)
                self.command[f] = min(1.0, ceiling, self.command[f] + self.close_speed * dt)
            elif self.state[f] == TOUCHED and not self.squeezing and finger_force[f] <= 0.0:
                self.state[f] = CLOSING  # it lost the object before the squeeze: close on from where it is
                self.command[f] = where[f]
                self._furthest[f], self._still_s[f] = moving_to[f], 0.0
        if not self.squeezing and grip_force >= self.contact_force:
            self._gripped_s += dt
        if not self.squeezing and (not np.any(self.state == CLOSING) or self._gripped_s >= self.wait_s):
            self.squeezing = True
            self.pi.reset()
        if self.squeezing:
            self._squeeze(grip_force, dt)
        closing = self.moving & np.isin(self.fingers, np.flatnonzero(self.state == CLOSING))
        rest = self.moving & ~closing
        offset = np.where(np.isin(self.fingers, np.flatnonzero(self.state == TOUCHED)), self.offset, 0.0)
        cmd = np.where(closing, self.command[np.clip(self.fingers, 0, None)],
                       np.where(rest, self.base + PRELOAD * self.leads + offset, 0.0))
        self.ctrl = np.where(self.moving, self.open + np.clip(cmd, 0.0, 1.0) * self.span, self.open)
        return self.ctrl.copy()

    def _rest(self, f: int, acts: np.ndarray, synergy: np.ndarray, state: int) -> None:
        """Finger `f` (actuators `acts`) stops where it stands (commanded `PRELOAD` past it)."""
        self.state[f] = state
        self.base[acts] = synergy[acts]
        self.touched_ever[f] |= state == TOUCHED

    def _squeeze(self, grip_force: float, dt: float) -> None:
        """Regulate the grip force by the offset of the touched fingers."""
        touched = self.moving & np.isin(self.fingers, np.flatnonzero(self.state == TOUCHED))
        if not touched.any():
            return
        if grip_force >= self.contact_force:
            self.mode = "force"
        if self.mode == "force":
            self._peak = max(self._peak, grip_force)
        k = self.full_force / max(1.0 - float(np.mean(self.base[touched])), 0.05)
        low, high = -PRELOAD * float(np.min(self.leads[touched])), 1.0
        error = (self.target_force - grip_force) / k
        out = self.pi.update(error, dt, push_up_blocked=self.offset >= high, push_down_blocked=self.offset <= low)
        self.offset = float(np.clip(out[0], low, high))
        at_bound = self.offset >= high and grip_force < self.contact_force
        self._saturated_s = self._saturated_s + dt if at_bound else 0.0
