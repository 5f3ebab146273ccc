"""`shake`: lift, then shake along and about the approach axis (ACRONYM-style).

Phases: as `lift` (pre-grasp, approach, close, lift 10 cm, hold 0.5 s), then
`shake_cycles` cycles of a sinusoidal set-point at `shake_frequency`: the TCP
moves +-`shake_amplitude` along its approach axis and turns
+-`shake_angle_deg` about it, in phase (peak acceleration 4 pi^2 f^2 A:
3.2 m/s^2 for the defaults). The object moving more than the thresholds in
the hand since the shaking began: `dropped_perturb` (detail "shake: ...", no
`perturb_direction`). Success also needs `min_fingers` fingers touching at the
end; a trial that passed the shaking has `last_phase` "shake".
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from manigrasp.errors import ConfigError
from manigrasp.geometry import axis_angle_to_mat
from manigrasp.protocol.base import Protocol, register
from manigrasp.protocol.execution import TrialRun
from manigrasp.protocol.grasp import Grasp
from manigrasp.protocol.lift import LiftParams, grasp_and_lift
from manigrasp.protocol.phases import require_fingers
from manigrasp.protocol.result import Phase, Status


@dataclass(frozen=True)
class ShakeParams(LiftParams):
    """`LiftParams` (with a 0.5 s hold) plus the shaking.

    Attributes:
        shake_amplitude: translation amplitude along the approach axis [m].
        shake_angle_deg: rotation amplitude about the approach axis [deg].
        shake_frequency: [Hz].
        shake_cycles: number of periods.
    """

    hold_s: float = 0.5
    shake_amplitude: float = 0.02
    shake_angle_deg: float = 15.0
    shake_frequency: float = 2.0
    shake_cycles: int = 3

    def __post_init__(self) -> None:
        super().__post_init__()
        if not (self.shake_amplitude >= 0 and self.shake_angle_deg >= 0 and self.shake_frequency > 0
                and self.shake_cycles >= 1):
            raise ConfigError("shake amplitudes must be >= 0, frequency > 0 and cycles >= 1")


def shake(run: TrialRun, p: ShakeParams) -> None:
    """Oscillate the set-point along and about its approach axis (module docstring)."""
    centre = run.impedance.target.copy()
    axis = centre[:3, 2].copy()
    omega, angle = 2 * math.pi * p.shake_frequency, math.radians(p.shake_angle_deg)
    n = run.n_steps(p.shake_cycles / p.shake_frequency)

    def trajectory(t: float) -> tuple[np.ndarray, np.ndarray]:
        s, c = math.sin(omega * t), math.cos(omega * t)
        pose = centre.copy()
        pose[:3, 3] += p.shake_amplitude * s * axis
        pose[:3, :3] = axis_angle_to_mat(axis, angle * s) @ centre[:3, :3]
        return pose, np.concatenate([p.shake_amplitude * omega * c * axis, angle * omega * c * axis])

    with run.phase(Phase.SHAKE, watch=Status.DROPPED_PERTURB):
        run.step(n, trajectory)
        run.hold_target(centre)


@register
class ShakeProtocol(Protocol[ShakeParams]):
    """Lift and shake (see the module docstring)."""

    name = "shake"
    Params = ShakeParams

    def body(self, run: TrialRun, pose: np.ndarray, rest: np.ndarray, grasp: Grasp) -> tuple[str, ...]:
        """Grasp, lift, then shake along and about the approach axis; two fingers must still touch."""
        grasp_and_lift(run, pose, rest, grasp)
        shake(run, self.params)
        return require_fingers(run, Status.DROPPED_PERTURB)
