"""The textbook's antipodal search (chapter 11, section 5.1), re-implemented faithfully as a speed reference.

Kept here only to time it against `manigrasp.planners.antipodal`; never use it
to plan. Its defects, kept on purpose:

- It compares every normal with every other in a Python double loop: O(n^2).
- It tests only the two normals, never the points: it never checks that the
  two points face each other along the line joining them (that line inside
  both friction cones), nor that a ray between them stays in the object.
- Its two angle tests contradict each other: "nearly opposite" means
  dot < -0.9, so arccos(|dot|) < 25.8 degrees, which then fails the
  "approach angle > 30 degrees" test; it returns no pair on any mesh.
- Its grasp frame is the identity (or a rotation built from an unrelated
  axis), not a frame whose closing axis is the grasp line.
"""

from __future__ import annotations

import numpy as np


class TextbookAntipodalPlanner:
    """The chapter's `AntipodalGraspPlanner`, with its constants."""

    def __init__(self) -> None:
        self.min_approach_angle = np.pi / 6  # 30 degrees
        self.max_grasp_width = 0.1  # 10 cm

    def find_antipodal_pairs(self, normals_1: np.ndarray, normals_2: np.ndarray) -> list[dict]:
        """Every pair (i, j) of nearly opposite normals passing the approach-angle test, best first."""
        antipodal_pairs = []
        for i, n1 in enumerate(normals_1):
            for j, n2 in enumerate(normals_2):
                dot_product = np.dot(n1, n2)
                if abs(dot_product + 1.0) < 0.1:
                    approach_angle = np.arccos(abs(dot_product))
                    if approach_angle > self.min_approach_angle:
                        antipodal_pairs.append({"pair": (i, j), "approach_angle": approach_angle,
                                                "quality": -dot_product})
        antipodal_pairs.sort(key=lambda x: x["quality"], reverse=True)
        return antipodal_pairs

    def plan_grasp(self, points: np.ndarray, normals: np.ndarray) -> list[dict]:
        """The chapter's `plan_grasp` on given surface points and normals (it used mesh vertices)."""
        antipodal_pairs = self.find_antipodal_pairs(normals, normals)
        valid_grasps = []
        for pair_info in antipodal_pairs[:100]:
            i, j = pair_info["pair"]
            p1, p2 = points[i], points[j]
            center = (p1 + p2) / 2
            grasp_width = np.linalg.norm(p1 - p2)
            if grasp_width < self.max_grasp_width:
                grasp_pose = np.eye(4)
                grasp_pose[:3, 3] = center
                valid_grasps.append({"pose": grasp_pose, "width": grasp_width, "quality": pair_info["quality"],
                                     "contact_points": [p1, p2], "contact_normals": [normals[i], normals[j]]})
        return valid_grasps
