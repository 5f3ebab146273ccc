"""Hold a closed grasp: stiffen the hand's finger servos around the configuration and forces they reached.

The dexterous hands close with soft position servos (a blocked finger pushes with kp (u - L), kp small) so that
the grip force can be regulated through the synergy (`GripController`). Left that way after closing, a finger
keeps the command u about 1 rad past its contact: when the object shifts under a load (the lift, a push), every
finger follows it, curling further at almost the same force, and the object rolls along the curling fingers
and out of the palm (`slipped_lift`, the main failure of `manigrasp bench dexterous`).

`FingerHold.engage` switches each position servo of the hand to a stiffness `gain` times its own and sets its
command just past where the finger stands, u' = L + f / kp', so every finger keeps the force f it had when the
grip was regulated (the target grip force) but now holds its joint configuration: a finger pushed open gains
force at kp', one that would curl on loses it. `release` restores the model's gains (the scene's model is
reused by the next trial).

Only actuators that are position servos (bias = -kp L - kv dL/dt, MuJoCo's ``position``) are changed;
anything else (motors, a user's custom actuators) is left alone.
"""

from __future__ import annotations

import mujoco
import numpy as np

from manigrasp.errors import ConfigError

# Stiffness of the held grasp relative to the closing servo's [-] (the protocols' `finger_hold_gain` is off by
# default): the robosuite hands' 0.5 N m/rad tendons hold at 10 N m/rad, the Allegro's 1 N m/rad joints at 20 (a
# finger moving 0.03 rad then changes its force by its whole 0.6-0.7 N m range). A can grasped by hand creeps
# about 1 mm at 20 (3-4 mm at 5, 12-20 mm without); but on the power planner's grasps of `bench dexterous` the
# held fingers stop following the object and more grasps drop under the perturbations (replayed, same grasps:
# inspire_right 21/80 held at 20 vs 32/80 not held, fourier_right 36 vs 39, allegro_right 2 vs 4).
HOLD_GAIN = 20.0


class FingerHold:
    """Stiffen (and restore) the position servos among `actuators` of `model`.

    Args:
        model: the scene's model (its gains are edited in place by `engage`, restored by `release`).
        actuators: ids of the hand's actuators.
        gain: stiffness multiple of the held grasp [-] (>= 1).
    """

    def __init__(self, model: mujoco.MjModel, actuators: np.ndarray, gain: float = HOLD_GAIN) -> None:
        if not gain >= 1.0:
            raise ConfigError(f"the hold gain must be >= 1, got {gain}")
        self.model, self.gain = model, float(gain)
        ids = np.asarray(actuators, dtype=int)
        kp, bias = model.actuator_gainprm[ids, 0], model.actuator_biasprm[ids, :3]
        servo = (model.actuator_gaintype[ids] == mujoco.mjtGain.mjGAIN_FIXED) & (
            model.actuator_biastype[ids] == mujoco.mjtBias.mjBIAS_AFFINE) & (kp > 0) & np.isclose(bias[:, 1], -kp) & (
            bias[:, 0] == 0)
        self.ids = ids[servo]
        self.kp = model.actuator_gainprm[self.ids, 0].copy()
        self.kv = -model.actuator_biasprm[self.ids, 2].copy()
        self.engaged = False

    def engage(self, data: mujoco.MjData) -> np.ndarray:
        """Stiffen the servos and set their commands so each keeps its current force; returns the commands.

        The commands are clamped to each actuator's control range (a finger already past its range keeps the
        range's end); the damping grows with sqrt(gain), keeping each servo's damping ratio.
        """
        m, ids = self.model, self.ids
        force = data.actuator_force[ids].copy()
        length = data.actuator_length[ids].copy()
        kp = self.gain * self.kp
        m.actuator_gainprm[ids, 0] = kp
        m.actuator_biasprm[ids, 1] = -kp
        m.actuator_biasprm[ids, 2] = -np.sqrt(self.gain) * self.kv
        ctrl = length + force / kp
        limited = m.actuator_ctrllimited[ids].astype(bool)
        low, high = m.actuator_ctrlrange[ids, 0], m.actuator_ctrlrange[ids, 1]
        ctrl = np.where(limited, np.clip(ctrl, low, high), ctrl)
        data.ctrl[ids] = ctrl
        self.engaged = True
        return ctrl

    def release(self) -> None:
        """Restore the closing gains (idempotent)."""
        m, ids = self.model, self.ids
        m.actuator_gainprm[ids, 0] = self.kp
        m.actuator_biasprm[ids, 1] = -self.kp
        m.actuator_biasprm[ids, 2] = -self.kv
        self.engaged = False
