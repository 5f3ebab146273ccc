"""A minimal user grasp planner for manigrasp (the example of docs/planners.md, "Your own planner").

Load it as ``top_down_planner:TopDownPlanner`` with this folder on the Python
path, e.g. ``PYTHONPATH=examples manigrasp plan --object mug --hand
parallel_jaw --planner top_down_planner:TopDownPlanner -n 8``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from manigrasp.planners import GraspCandidate


@dataclass(frozen=True)
class TopDownPlanner:
    """Straight down onto the centre of mass, the jaw turned through n evenly spaced yaws."""

    name = "top_down"
    needs = "mesh"  # reads observation.object_pose (and could read observation.mesh)
    height: float = 0.0  # [m] TCP above the centre of mass

    def plan(self, observation, hand, n, rng):
        """n poses, best first; rng (a numpy Generator) only turns the first yaw."""
        first = rng.uniform(0.0, np.pi / n)
        candidates = []
        for k in range(n):
            yaw = first + k * np.pi / n
            pose = np.eye(4)
            pose[:3, 2] = [0.0, 0.0, -1.0]  # z: approach, from above
            pose[:3, 1] = [np.cos(yaw), np.sin(yaw), 0.0]  # y: closing
            pose[:3, 0] = np.cross(pose[:3, 1], pose[:3, 2])  # x = y cross z
            pose[:3, 3] = observation.center_of_mass + [0.0, 0.0, self.height]
            candidates.append(GraspCandidate(pose=pose, score=1.0 - k / n, width=hand.max_width))
        return candidates
