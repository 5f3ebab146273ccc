"""Planners that misbehave, loaded by the harness tests as ``faulty_planners:NAME``."""

from __future__ import annotations

import numpy as np

from manigrasp.planners import GraspCandidate


class Raises:
    """A planner that always raises."""

    name = "raises"
    needs = "mesh"

    def plan(self, observation, hand, n, rng):
        raise RuntimeError("planner exploded")


class ReturnsNaN:
    """A planner whose only candidate has a NaN pose."""

    name = "returns_nan"
    needs = "mesh"

    def plan(self, observation, hand, n, rng):
        pose = np.eye(4)
        pose[0, 3] = np.nan
        return [GraspCandidate(pose=pose, score=1.0)]
