"""`random`: uniform random grasp poses near the object, approach pointing at it, no filtering.

The floor every planner must beat. The TCP is uniform in a ball of radius
`spread` x the object's radius around its centre of mass, so the hand, coming
along its approach, points at the object; the approach is uniform over the
directions that do not come from below the table (z component <= 0); the roll
about the approach is uniform. Nothing is checked: not collisions, not
contacts. Every candidate scores 0 and carries no metrics.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from manigrasp.errors import ConfigError
from manigrasp.geometry import perpendicular_basis
from manigrasp.hands.base import Hand
from manigrasp.planners.base import GraspCandidate, Observation, ObservationKind
from manigrasp.planners.context import PlanContext, resolve
from manigrasp.planners.geometry import tcp_frames


@dataclass(frozen=True)
class RandomPlanner:
    """Random poses near the object (module docstring).

    Attributes:
        spread: radius of the TCP ball as a fraction of the object's radius [-].
        pregrasp_offset: pre-grasp distance back along the approach [m] given to the candidates; None: the
            protocol's (`PlanContext.pregrasp_offset`).
    """

    name: ClassVar[str] = "random"
    needs: ClassVar[ObservationKind] = "mesh"

    spread: float = 0.5
    pregrasp_offset: float | None = None

    def __post_init__(self) -> None:
        if not self.spread >= 0:
            raise ConfigError(f"random: spread must be >= 0, got {self.spread}")

    def plan(self, observation: Observation, hand: Hand, n: int, rng: np.random.Generator,
             context: PlanContext | None = None) -> list[GraspCandidate]:
        """`n` random poses, all scored 0 (their pre-grasp offset: `context`'s, None: the standard protocol's)."""
        back = resolve(context, self.pregrasp_offset).pregrasp_offset
        center = observation.center_of_mass
        vertices = np.asarray(observation.world_mesh().vertices)
        radius = float(np.max(np.linalg.norm(vertices - center, axis=1)))
        approach = rng.normal(size=(n, 3))
        approach /= np.linalg.norm(approach, axis=1, keepdims=True)
        approach[:, 2] = -np.abs(approach[:, 2])  # from above (or level), never from below the table
        offset = rng.normal(size=(n, 3))
        offset *= (self.spread * radius * rng.random(n) ** (1.0 / 3.0) / np.linalg.norm(offset, axis=1))[:, None]
        a, b = perpendicular_basis(approach)
        roll = rng.random(n) * 2.0 * np.pi
        closing = np.cos(roll)[:, None] * a + np.sin(roll)[:, None] * b
        poses = tcp_frames(center + offset, approach, closing)
        return [GraspCandidate(pose=p, score=0.0, preshape=0.0, pregrasp_offset=back,
                               planner=self.name) for p in poses]
