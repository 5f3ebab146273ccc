"""`standard`: DESIGN.md's lift-and-perturb protocol.

Phases and defaults (every number a field of `StandardParams`):
settle (the harness plans on the resting pose) -> pre-grasp: the open hand
10 cm back along the approach axis, any hand contact is `pregrasp_collision`
-> approach by Cartesian impedance at 0.1 m/s -> close by the hybrid grip
controller to half the hand's maximum grip force (no object contact:
`no_contact`) -> lift 10 cm at 0.1 m/s and hold 0.5 s (object moving more
than 2 cm / 15 deg in the hand, or left behind: `slipped_lift`) -> perturb:
a force of 1 x m g at the object's centre of mass along +x, -x, +y, -y, +z,
-z (world) for 0.5 s each (object moving more than 2 cm / 15 deg in the hand
since the perturbation began: `dropped_perturb`, its `perturb_direction` the direction).
Success also needs >= 2 distinct finger bodies touching the object at the end.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from manigrasp.errors import ConfigError
from manigrasp.protocol.base import Protocol, register
from manigrasp.protocol.execution import TrialRun
from manigrasp.protocol.grasp import Grasp
from manigrasp.protocol.lift import LiftParams, grasp_and_lift
from manigrasp.protocol.phases import require_fingers
from manigrasp.protocol.result import DIRECTIONS as DIRECTION_NAMES
from manigrasp.protocol.result import Phase, Status

DIRECTIONS = dict(zip(DIRECTION_NAMES, ((1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)),
                      strict=True))
"""Each perturbation direction's name and world unit vector."""


@dataclass(frozen=True)
class StandardParams(LiftParams):
    """`LiftParams` (with a 0.5 s hold) plus the perturbation.

    Attributes:
        perturb_force_multiple: force magnitude in units of the object's weight m g [-].
        perturb_s: duration of each direction's force [s].
        perturb_directions: world directions, in order, from "+x", "-x", "+y", "-y", "+z", "-z".
    """

    hold_s: float = 0.5
    perturb_force_multiple: float = 1.0
    perturb_s: float = 0.5
    perturb_directions: tuple[str, ...] = ("+x", "-x", "+y", "-y", "+z", "-z")

    def __post_init__(self) -> None:
        super().__post_init__()
        if not (self.perturb_force_multiple >= 0 and self.perturb_s > 0):
            raise ConfigError("perturb_force_multiple must be >= 0 and perturb_s > 0")
        bad = [d for d in self.perturb_directions if d not in DIRECTIONS]
        if bad:
            raise ConfigError(f"unknown perturbation direction(s) {bad}; available: {', '.join(DIRECTIONS)}")


def perturb(run: TrialRun, multiple: float, seconds: float, directions: tuple[str, ...]) -> None:
    """Push the object's centre of mass with `multiple` x m g along each direction for `seconds` [s].

    One phase: the object's motion in the hand counts from before the first push; each direction is
    a phase nested in it (the observer hears "perturb" with the direction as it begins).
    """
    scene = run.scene
    weight = scene.object_mass() * float(np.linalg.norm(scene.model.opt.gravity))
    applied = scene.data.xfrc_applied[scene.object_body]
    with run.phase(Phase.PERTURB, watch=Status.DROPPED_PERTURB, announce=False):
        try:
            for name in directions:
                with run.phase(Phase.PERTURB, name):
                    applied[:3] = multiple * weight * np.asarray(DIRECTIONS[name], float)
                    run.hold_for(seconds)
        finally:
            applied[:] = 0.0


@register
class StandardProtocol(Protocol[StandardParams]):
    """Lift and perturb (see the module docstring)."""

    name = "standard"
    Params = StandardParams

    def body(self, run: TrialRun, pose: np.ndarray, rest: np.ndarray, grasp: Grasp) -> tuple[str, ...]:
        """Grasp, lift, then push the object along each direction; at least two fingers must still touch."""
        p = self.params
        grasp_and_lift(run, pose, rest, grasp)
        perturb(run, p.perturb_force_multiple, p.perturb_s, p.perturb_directions)
        return require_fingers(run, Status.DROPPED_PERTURB)
