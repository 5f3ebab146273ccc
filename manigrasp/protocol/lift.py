"""`lift`: close, lift 10 cm and hold (no perturbation).

Phases: pre-grasp (any hand contact: `pregrasp_collision`), approach by
Cartesian impedance, close to the grip force (`no_contact`), lift and hold
`hold_s` (object slipping past the thresholds or left behind:
`slipped_lift`). Success also needs `min_fingers` distinct fingers touching
the object at the end.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from manigrasp.errors import ConfigError
from manigrasp.protocol.base import Protocol, register
from manigrasp.protocol.execution import GraspParams, TrialRun
from manigrasp.protocol.grasp import Grasp
from manigrasp.protocol.phases import approach, close, lift, place_pregrasp, require_fingers
from manigrasp.protocol.result import Status


@dataclass(frozen=True)
class LiftParams(GraspParams):
    """`GraspParams` plus the lift.

    Attributes:
        lift_height: how far the hand rises after closing [m].
        lift_speed: speed of the lift set-point [m/s].
        hold_s: time held at the top [s].
    """

    lift_height: float = 0.10
    lift_speed: float = 0.10
    hold_s: float = 2.0

    def __post_init__(self) -> None:
        super().__post_init__()
        if not (self.lift_height > 0 and self.lift_speed > 0 and self.hold_s >= 0):
            raise ConfigError("lift_height and lift_speed must be > 0 and hold_s >= 0")


def grasp_and_lift(run: TrialRun, pose: np.ndarray, rest: np.ndarray, grasp: Grasp) -> None:
    """The phases shared by `lift` and `standard`: pre-grasp, approach, close, lift and hold."""
    p: LiftParams = run.params  # type: ignore[assignment]
    start = place_pregrasp(run, pose, rest, grasp.preshape)
    approach(run, start, pose)
    close(run, grasp.preshape)
    lift(run, p.lift_height, p.lift_speed, p.hold_s)


@register
class LiftProtocol(Protocol[LiftParams]):
    """Lift and hold (see the module docstring)."""

    name = "lift"
    Params = LiftParams

    def body(self, run: TrialRun, pose: np.ndarray, rest: np.ndarray, grasp: Grasp) -> tuple[str, ...]:
        """Grasp, lift and hold; at least two fingers must still touch."""
        grasp_and_lift(run, pose, rest, grasp)
        return require_fingers(run, Status.SLIPPED_LIFT)
