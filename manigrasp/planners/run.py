"""Running a planner: check the observation, time the call, validate and rank what comes back.

This is the one place that reads the clock (planners themselves do not).
Anything a planner raises, and any invalid candidate it returns (NaN pose,
a rotation that is not one, too many candidates...), becomes a `PlannerError`
whose message names the planner and the defect.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence
from dataclasses import dataclass
from numbers import Real

import numpy as np

from manigrasp.errors import PlannerError
from manigrasp.geometry import rigid_defect
from manigrasp.hands.base import Hand
from manigrasp.planners.base import GraspCandidate, Observation, Planner
from manigrasp.planners.context import PlanContext, takes_context


@dataclass(frozen=True)
class PlanResult:
    """The ranked candidates of one planning call.

    Attributes:
        planner: the planner's name.
        candidates: best first (sorted by score, stable).
        planning_time_s: wall time of the planner's `plan` call [s].
    """

    planner: str
    candidates: tuple[GraspCandidate, ...]
    planning_time_s: float


# Largest pre-grasp offset a candidate may ask for [m]: the approach from it at the protocols' 0.1 m/s takes 10 s (a
# planner's 1000 m waited out each trial's time budget and was stored as a timeout).
MAX_PREGRASP_OFFSET = 1.0


def _text(exc: BaseException) -> str:
    """`str(exc)`, or what can be said of it when its own `__str__` fails."""
    try:
        return str(exc)
    except Exception as inner:  # noqa: BLE001 (a user's exception type: anything may come out of it)
        return f"<its message could not be read: {type(inner).__name__}>"


def planner_name(planner: object) -> str:
    """The planner's `name`, or its class name if it has none."""
    return str(getattr(planner, "name", type(planner).__name__))


def accepted_kinds(planner: object) -> tuple[str, ...]:
    """The observation kinds `planner` can plan from, preferred first: its `needs` ("mesh", "points", or a
    tuple of them; "mesh" if it declares nothing)."""
    needs = getattr(planner, "needs", "mesh")
    return (needs,) if isinstance(needs, str) else tuple(needs)


def plan(planner: Planner, observation: Observation, hand: Hand, n: int, rng: np.random.Generator,
         context: PlanContext | None = None) -> PlanResult:
    """Run `planner` for at most `n` grasps of `hand`; validated, ranked and timed.

    `context`: the parameters of the protocol that will execute the grasps and of its scene (`PlanContext.for_run`),
    passed on to a planner whose ``plan`` takes a ``context`` keyword; None: each planner's default
    (the standard protocol's, the default scene).

    Raises:
        PlannerError: the planner raised, needs an observation it was not
            given, or returned something that is not a valid ranked list.
    """
    name = planner_name(planner)
    if n < 1:
        raise PlannerError(f"the number of grasps must be >= 1, got {n}")
    if not isinstance(rng, np.random.Generator):
        raise PlannerError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    needs = accepted_kinds(planner)
    if not set(needs) & set(observation.kinds):
        raise PlannerError(f"planner {name!r} needs a {' or '.join(needs)} observation; this one has: "
                           f"{', '.join(observation.kinds)}")
    start = time.perf_counter()
    try:
        extra = {"context": context} if context is not None and takes_context(planner) else {}
        returned = planner.plan(observation, hand, n, rng, **extra)
    except KeyboardInterrupt:  # Ctrl-C (it reaches the planner's worker too): the run stops, nothing is recorded
        raise
    except BaseException as exc:  # a planner's failure (even sys.exit, a CancelledError) is reported, never swallowed
        raise PlannerError(f"planner {name!r} raised {type(exc).__name__}: {_text(exc)}") from exc
    elapsed = time.perf_counter() - start
    candidates = validate_candidates(returned, name, n, hand)
    order = sorted(range(len(candidates)), key=lambda i: -candidates[i].score)
    # As plain `GraspCandidate`s: a planner's own subclass (one defined in a function, say) need not pickle to the
    # harness's worker pool, and carries nothing the trials read.
    ranked = tuple(GraspCandidate(**{f.name: getattr(candidates[i], f.name) for f in dataclasses.fields(GraspCandidate)
                                     if f.init} | {"planner": candidates[i].planner or name,
                                                   "planning_time_s": elapsed}) for i in order)
    return PlanResult(planner=name, candidates=ranked, planning_time_s=elapsed)


def validate_candidates(returned: object, name: str, n: int, hand: Hand | None = None) -> list[GraspCandidate]:
    """`returned` as a list of valid candidates (for `hand`, if given), else a `PlannerError` naming the
    first defect."""
    if not isinstance(returned, Sequence) or isinstance(returned, str | bytes):
        raise PlannerError(f"planner {name!r} returned {type(returned).__name__}, not a list of GraspCandidate")
    if len(returned) > n:
        raise PlannerError(f"planner {name!r} returned {len(returned)} candidates, more than the {n} asked for")
    for i, candidate in enumerate(returned):
        if not isinstance(candidate, GraspCandidate):
            raise PlannerError(f"planner {name!r}: candidate {i} is a {type(candidate).__name__}, "
                               "not a GraspCandidate")
        defect = candidate_defect(candidate, hand)
        if defect:
            raise PlannerError(f"planner {name!r}: candidate {i} is invalid: {defect}")
    return list(returned)


def candidate_defect(candidate: GraspCandidate, hand: Hand | None = None) -> str | None:
    """What is wrong with `candidate` (a sentence), or None if it is valid (or declared `invalid`:
    then its trial is `invalid_grasp`; only its score must rank).

    The pose must be rigid within `manigrasp.geometry.RIGID_TOLERANCE` (the protocol's own check);
    `joints`, if given, a finite (2, n_actuators) array for a dexterous `hand` (`protocol.grasp.joints_defect`;
    whether the path can be executed, rows that differ inside the actuators' ranges, is the protocol's check
    on the compiled scene: `invalid_grasp`)."""
    for key in ("score", "preshape", "pregrasp_offset", "width"):
        value = getattr(candidate, key)
        if not (value is None and key in ("width", "pregrasp_offset")) and (isinstance(value, bool)
                                                                       or not isinstance(value, Real)):
            return f"{key} is {value!r}, not a number"
    for key in ("pose", "contacts", "contact_normals"):
        value = getattr(candidate, key)
        if not isinstance(value, np.ndarray) or not np.issubdtype(value.dtype, np.number):
            return f"{key} is a {type(value).__name__}, not a numeric array"
    if candidate.invalid:
        return None if np.isfinite(candidate.score) else f"score is {candidate.score}"
    defect = rigid_defect(candidate.pose)
    if defect is not None:
        return f"pose {defect}"
    if not np.isfinite(candidate.score):
        return f"score is {candidate.score}"
    if candidate.width is not None and not (np.isfinite(candidate.width) and candidate.width >= 0):
        return f"width is {candidate.width}"
    if not (0.0 <= candidate.preshape <= 1.0):
        return f"preshape {candidate.preshape} is outside [0, 1]"
    if candidate.contacts.shape != candidate.contact_normals.shape:
        return "contacts and contact_normals differ in shape"
    if not (np.all(np.isfinite(candidate.contacts)) and np.all(np.isfinite(candidate.contact_normals))):
        return "contacts contain NaN or inf"
    friction = candidate.contact_friction
    if friction is not None and (not isinstance(friction, np.ndarray) or friction.shape != (len(candidate.contacts), 2)
                                 or not np.all(np.isfinite(friction)) or np.any(friction < 0)):
        return "contact_friction is not a (k, 2) array of finite frictions >= 0, one row per contact"
    offset = candidate.pregrasp_offset
    if offset is not None and not (np.isfinite(offset) and 0 <= offset <= MAX_PREGRASP_OFFSET):
        return (f"pregrasp_offset is {candidate.pregrasp_offset} (a distance in [0, {MAX_PREGRASP_OFFSET:g}] m back "
                "along the approach)")
    if candidate.joints is not None:
        from manigrasp.protocol.grasp import joints_defect

        return joints_defect(candidate.joints, hand, executable=False)
    return None
