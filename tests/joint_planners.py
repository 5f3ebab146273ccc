"""A test planner for dexterous grasps with their own joints (loaded as ``joint_planners:SideGrasps``)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from manigrasp.hands.placement import side_power_grasp
from manigrasp.planners import GraspCandidate


def side_grasp(hand, object_pose: np.ndarray) -> np.ndarray:
    """TCP pose of a side power grasp of a standing can through its centre: can axis along TCP x, thumb side up."""
    return side_power_grasp(hand, object_pose[:3, 3])


def own_path(hand) -> np.ndarray:
    """(2, n_act) a path that is not the hand's own: from 20 % closed to 90 % of its closed command."""
    span = hand.closed_ctrl - hand.open_ctrl
    return np.stack([hand.open_ctrl + 0.2 * span, hand.open_ctrl + 0.9 * span])


@dataclass(frozen=True)
class SideGrasps:
    """Grasp 0: the side power grasp on its own path; grasp 1: the same 15 cm above the can (closes on air)."""

    name: ClassVar[str] = "side_grasps"
    needs: ClassVar[str] = "mesh"

    def plan(self, observation, hand, n, rng):
        pose = side_grasp(hand, observation.object_pose)
        above = pose.copy()
        above[2, 3] += 0.15
        joints = own_path(hand)
        return [GraspCandidate(pose=pose, score=1.0, joints=joints),
                GraspCandidate(pose=above, score=0.5, joints=joints)][:n]
