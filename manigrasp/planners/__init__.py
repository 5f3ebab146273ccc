"""Grasp planners: a `Planner` protocol, a registry and our planners (antipodal, power, random, file).

    >>> from manigrasp import planners
    >>> obs = planners.Observation.from_asset(asset)
    >>> result = planners.plan(planners.load("antipodal"), obs, hands.load("parallel_jaw"), 100,
    ...                        np.random.default_rng(0))
    >>> result.candidates[0].pose   # (4, 4) TCP pose in the world, best first
"""

from manigrasp.geometry import pregrasp_pose as pregrasp  # (..., 4, 4) poses moved back along their approach
from manigrasp.planners.base import (
    PREGRASP_OFFSET,
    GraspCandidate,
    Observation,
    ObservationKind,
    Planner,
    resting_pose,
)
from manigrasp.planners.registry import PLANNERS, load, names
from manigrasp.planners.run import PlanResult, accepted_kinds, candidate_defect, plan, validate_candidates

__all__ = [
    "PLANNERS",
    "PREGRASP_OFFSET",
    "GraspCandidate",
    "Observation",
    "ObservationKind",
    "PlanResult",
    "Planner",
    "accepted_kinds",
    "candidate_defect",
    "load",
    "names",
    "plan",
    "pregrasp",
    "resting_pose",
    "validate_candidates",
]
