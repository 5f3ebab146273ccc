"""What the protocol that will execute a plan tells its planner: `PlanContext`.

A planner that checks the open hand for collisions must check it where the
protocol will put it (the pre-grasp pose, `pregrasp_offset` back along the
approach), and a planner that ranks grasps by how well they hold must know the
grip force the protocol closes to and the loads it applies. These are the
protocol's parameters, not the planner's: the harness passes them to
`manigrasp.planners.plan`, which hands them to every planner whose ``plan``
accepts a ``context`` keyword (older planners are called without it).
Without a protocol (``manigrasp plan``, a planner called directly) the
context is the standard protocol's defaults (`PlanContext.standard`).

The context also carries the run's scene (`PlanContext.scene`, a `SceneConfig`):
a planner that compiles the hand to probe it (`collision.HandProbe`) must
compile the hand the trials run, e.g. with rigid pads under ``pads: rigid``
(the compliant pads' scene cuts some hands' finger hulls behind the pads,
`manigrasp.hands.pads`). The harness builds the context with `PlanContext.for_run`.
Measured (quick's 5 objects, seed 0, antipodal): compliant runs plan exactly as
before (100/100 parallel_jaw plans identical); a ``pads: rigid`` Panda run's plans
change (95/100: the rigid fingers reach 16.1 mm beyond the TCP, the cut ones
14.7 mm, which sets antipodal's pose grid), none of the old ones collided with
the uncut hulls (0/100), and it succeeds as often (86/100 before and after).
"""

from __future__ import annotations

import inspect
import math
from dataclasses import dataclass, replace
from functools import cache
from typing import Any

from manigrasp.errors import ConfigError
from manigrasp.hands.base import Hand
from manigrasp.planners.hold import GRAVITY
from manigrasp.sim.config import SceneConfig


@dataclass(frozen=True)
class PlanContext:
    """The execution parameters a plan is made for (from the protocol's parameters: `from_params`).

    Attributes:
        pregrasp_offset: the open hand starts this far back along the approach axis [m]; a planner
            checks the hand for collisions there as well as at the grasp.
        grip_force: the grip force the protocol closes to [N], or None: `grip_fraction` of the
            hand's maximum (`grip_force_for`).
        grip_fraction: the protocol's grip force as a fraction of the hand's `max_grip_force` when
            `grip_force` is None [-].
        perturbation: the largest load beyond the object's weight that the protocol applies, in units
            of the object's weight m g, taken along each of +-x, +-y, +-z [-] (0: the weight only).
        contact_friction: sliding friction [-] of the hand surfaces that grasp in this scene
            (`grasping_friction`), or None: unknown, each planner assumes its own. A planner with its
            own contact model may ignore it (antipodal and power do; dexopt's hold test uses it).
        scene: the run's scene parameters, or None: the default `SceneConfig` (`scene_config`). A planner
            compiles its probing scenes with them (`collision.HandProbe`), so that it tests the hand the trials
            run (compliant or rigid pads). Its object-rest settings (``rest``, ``rest_k``, ``rest_index``) are
            reset to their defaults: a planner's scene puts the object at its observed pose itself, and a
            probe's stand-in object (a point cloud's hull) may not have the run's stable poses.
        rest_index: the rank of the stable pose the trials place the object in under ``rest: stable_k`` (taken
            from `scene` before its reset; the group's ``<object>@rest<i>``), else None. The `file` planner picks
            that pose's file of a `manigrasp label` dataset directory by it.
    """

    pregrasp_offset: float
    grip_force: float | None
    grip_fraction: float
    perturbation: float
    contact_friction: float | None = None
    scene: SceneConfig | None = None
    rest_index: int | None = None

    def __post_init__(self) -> None:
        if not (math.isfinite(self.pregrasp_offset) and self.pregrasp_offset >= 0):
            raise ConfigError(f"pregrasp_offset must be a finite distance >= 0 [m], got {self.pregrasp_offset}")
        if self.grip_force is not None and not self.grip_force > 0:
            raise ConfigError(f"grip_force must be > 0 or None, got {self.grip_force}")
        if not 0 < self.grip_fraction <= 1:
            raise ConfigError(f"grip_fraction must be in (0, 1], got {self.grip_fraction}")
        if not (math.isfinite(self.perturbation) and self.perturbation >= 0):
            raise ConfigError(f"perturbation must be >= 0, got {self.perturbation}")
        if self.contact_friction is not None and not (math.isfinite(self.contact_friction)
                                                      and self.contact_friction >= 0):
            raise ConfigError(f"contact_friction must be a finite friction >= 0 or None, got {self.contact_friction}")
        if self.scene is not None:
            if not isinstance(self.scene, SceneConfig):
                raise ConfigError(f"scene must be a SceneConfig or None, got {type(self.scene).__name__}")
            if self.scene.rest == "stable_k" and self.rest_index is None:
                object.__setattr__(self, "rest_index", self.scene.rest_index)
            placed = replace(self.scene, rest="file", rest_k=None, rest_index=0)
            if placed != self.scene:
                object.__setattr__(self, "scene", placed)

    def scene_config(self) -> SceneConfig:
        """The scene parameters a planner compiles its scenes with: `scene`, or the default `SceneConfig`."""
        return self.scene if self.scene is not None else SceneConfig()

    def grip_force_for(self, hand: Hand) -> float:
        """The grip force [N] the protocol closes `hand` to (capped at its maximum, as the close phase does)."""
        target = self.grip_force if self.grip_force is not None else self.grip_fraction * hand.max_grip_force
        return min(target, hand.max_grip_force)

    @classmethod
    def for_run(cls, params: Any, scene: SceneConfig, hand: Hand) -> PlanContext:
        """The context of a run: its protocol's parameters (`from_params`), its scene `scene` and the friction
        of `hand`'s grasping surfaces in it (`grasping_friction`)."""
        return cls.from_params(params, grasping_friction(scene, hand), scene=scene)

    @classmethod
    def from_params(cls, params: Any, contact_friction: float | None = None,
                    scene: SceneConfig | None = None) -> PlanContext:
        """The context of a protocol's parameters (a `protocol.execution.GraspParams` or a subclass), in a
        scene whose grasping surfaces have `contact_friction` (None: unknown; `grasping_friction`), of
        parameters `scene` (None: the default `SceneConfig`).

        The perturbation is the protocol's own load in units of m g: `perturb_force_multiple` (standard),
        `force_multiple` (six_direction), the peak acceleration of the shaking over g
        (`shake_amplitude` (2 pi `shake_frequency`)^2 / g, shake), else 0 (lift: the weight only).
        """
        if hasattr(params, "perturb_force_multiple"):
            perturbation = float(params.perturb_force_multiple)
        elif hasattr(params, "force_multiple"):
            perturbation = float(params.force_multiple)
        elif hasattr(params, "shake_amplitude"):
            omega = 2 * math.pi * float(params.shake_frequency)
            perturbation = float(params.shake_amplitude) * omega * omega / GRAVITY
        else:
            perturbation = 0.0
        return cls(pregrasp_offset=float(params.pregrasp_offset), grip_force=params.grip_force,
                   grip_fraction=float(params.grip_force_fraction), perturbation=perturbation,
                   contact_friction=None if contact_friction is None else float(contact_friction), scene=scene)

    @staticmethod
    def standard() -> PlanContext:
        """The context of the standard protocol at its defaults (the benchmark's protocol)."""
        return _standard()


@cache
def _standard() -> PlanContext:
    from manigrasp.protocol.standard import StandardParams

    return PlanContext.from_params(StandardParams())


def grasping_friction(scene: SceneConfig, hand: Hand) -> float:
    """The sliding friction [-] of `hand`'s grasping surfaces against the object in a scene of `scene`
    (a `manigrasp.sim.SceneConfig`): with ``pads: compliant``, the rubber's `pad_friction` if the hand has
    pads or rubber-covered fingertips (`Hand.pad_geoms`, `Hand.fingertip_geoms`); otherwise, and with
    ``pads: rigid``, `hand_friction` (the hand geoms take contact priority, so theirs is the contact's)."""
    if scene.pads == "compliant" and (hand.pad_geoms or hand.fingertip_geoms):
        return float(scene.pad_friction)
    return float(scene.hand_friction)


def resolve(context: PlanContext | None, pregrasp_offset: float | None = None, grip_fraction: float | None = None,
            perturbation: float | None = None) -> PlanContext:
    """`context` (None: `PlanContext.standard()`) with a planner's own settings where it has them (not None).

    A planner's own `grip_fraction` replaces the protocol's grip force as well as its fraction.
    """
    out = context if context is not None else PlanContext.standard()
    if pregrasp_offset is not None:
        out = replace(out, pregrasp_offset=float(pregrasp_offset))
    if grip_fraction is not None:
        out = replace(out, grip_force=None, grip_fraction=float(grip_fraction))
    if perturbation is not None:
        out = replace(out, perturbation=float(perturbation))
    return out


def takes_context(planner: object) -> bool:
    """Whether `planner.plan` accepts a ``context`` keyword (planners written before it existed do not)."""
    try:
        parameters = inspect.signature(planner.plan).parameters  # type: ignore[attr-defined]
    except (AttributeError, TypeError, ValueError):
        return False
    named = parameters.get("context")
    if named is not None:
        return named.kind in (inspect.Parameter.POSITIONAL_OR_KEYWORD, inspect.Parameter.KEYWORD_ONLY)
    return any(p.kind is inspect.Parameter.VAR_KEYWORD for p in parameters.values())
