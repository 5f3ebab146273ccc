"""`six_direction`: the gravity-free six-direction test of DexGraspBench, so results can be compared.

Phases: pre-grasp check as in `standard` (the open hand 10 cm back along the
approach axis must touch nothing, table included); then gravity is switched
off and the table made non-colliding, and for each of +x, -x, +y, -y, +z, -z
(world) from a fresh reset: the open hand at the grasp pose squeezes to the
grip force (`no_contact` if it closes on air), then a force of 10 N per kg
of the object's mass (`force_multiple` 1.02 m g_0, g_0 = 9.81 m/s^2: about
the object's weight on Earth) pushes the object's centre of mass for 2 s;
the object moving more than 5 cm or 15 deg relative to the hand fails the
trial as `dropped_perturb` (its `perturb_direction` the direction), and so do
fewer than `min_fingers` fingers touching at the end of any direction.
The scene's gravity and table are restored afterwards, whatever happens.

The load is DexGraspBench's: its force-closure test applies ``10 * direction * obj_mass``
newtons to the object (its `FCMocapEval`; mass 0.1 kg, friction 0.6, 5 cm / 15 deg thresholds
in its `config/task/eval.yaml`). Until 2026-12-03 this protocol applied 10 m g_0, ten times
that load, so its results of that time are not DexGraspBench's (docs/planners.md, "Measurements and history").
Unlike DexGraspBench, the object keeps its own mass and the hand squeezes to a grip force
(`GraspParams`) instead of commanding a squeeze pose.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from manigrasp.contact.defaults import STANDARD_GRAVITY
from manigrasp.errors import ConfigError
from manigrasp.protocol.base import Protocol, register
from manigrasp.protocol.execution import GraspParams, TrialRun
from manigrasp.protocol.grasp import Grasp
from manigrasp.protocol.phases import close, place_pregrasp, require_fingers, reset
from manigrasp.protocol.result import Phase, Status
from manigrasp.protocol.standard import DIRECTIONS

DEXGRASPBENCH_FORCE_PER_KG = 10.0  # [N/kg] the external force per kg of object mass (module docstring)


@dataclass(frozen=True)
class SixDirectionParams(GraspParams):
    """`GraspParams` (thresholds 5 cm / 15 deg) plus the external force.

    Attributes:
        force_multiple: force magnitude in units of m g_0 [-] (default DexGraspBench's 10 N per kg:
            `DEXGRASPBENCH_FORCE_PER_KG` / g_0 = 1.0194).
        force_s: duration of each direction's force [s].
        directions: world directions, in order.
        disable_table: make the table non-colliding during the test (DexGraspBench has no table).
    """

    translation_threshold: float = 0.05
    force_multiple: float = DEXGRASPBENCH_FORCE_PER_KG / STANDARD_GRAVITY
    force_s: float = 2.0
    directions: tuple[str, ...] = ("+x", "-x", "+y", "-y", "+z", "-z")
    disable_table: bool = True

    def __post_init__(self) -> None:
        super().__post_init__()
        if not (self.force_multiple >= 0 and self.force_s > 0):
            raise ConfigError("force_multiple must be >= 0 and force_s > 0")
        bad = [d for d in self.directions if d not in DIRECTIONS]
        if bad:
            raise ConfigError(f"unknown direction(s) {bad}; available: {', '.join(DIRECTIONS)}")
        if not self.directions:  # no direction: the hand would never close, and the trial would pass
            raise ConfigError(f"directions must name at least one of {', '.join(DIRECTIONS)}")


def six_directions(run: TrialRun, pose: np.ndarray, rest: np.ndarray, grasp: Grasp) -> tuple[str, ...]:
    """The protocol's phases (module docstring); returns the fingers touching at the end."""
    p: SixDirectionParams = run.params  # type: ignore[assignment]
    scene, model = run.scene, run.scene.model
    place_pregrasp(run, pose, rest, grasp.preshape)
    saved = (model.opt.gravity.copy(), int(model.geom_contype[scene.table_geom]),
             int(model.geom_conaffinity[scene.table_geom]))
    force = p.force_multiple * scene.object_mass() * STANDARD_GRAVITY
    try:
        model.opt.gravity[:] = 0.0
        if p.disable_table:
            model.geom_contype[scene.table_geom] = model.geom_conaffinity[scene.table_geom] = 0
        for i, name in enumerate(p.directions):
            reset(run, pose, rest, grasp.preshape)  # the previous direction's finger hold released
            close(run, grasp.preshape, metrics=i == 0, detail=name)
            with run.phase(Phase.PERTURB, name, watch=Status.DROPPED_PERTURB, reference=run.in_hand):
                scene.data.xfrc_applied[scene.object_body, :3] = force * np.asarray(DIRECTIONS[name], float)
                run.hold_for(p.force_s)
                scene.data.xfrc_applied[scene.object_body] = 0.0
                fingers = require_fingers(run, Status.DROPPED_PERTURB, name)
        return fingers
    finally:
        scene.data.xfrc_applied[scene.object_body] = 0.0
        model.opt.gravity[:] = saved[0]
        model.geom_contype[scene.table_geom], model.geom_conaffinity[scene.table_geom] = saved[1], saved[2]


@register
class SixDirectionProtocol(Protocol[SixDirectionParams]):
    """DexGraspBench's six-direction test (see the module docstring)."""

    name = "six_direction"
    Params = SixDirectionParams

    def body(self, run: TrialRun, pose: np.ndarray, rest: np.ndarray, grasp: Grasp) -> tuple[str, ...]:
        """Each direction from a reset, gravity and table off (see `six_directions`)."""
        return six_directions(run, pose, rest, grasp)
