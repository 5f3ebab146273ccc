"""What one trial returns: a status from a fixed vocabulary and its measurements.

A failure is a status, never a missing row or a score: every trial the
harness enumerates ends as exactly one `TrialResult`.

Two statuses fail a trial before it is simulated, both counted against the planner:
`planner_error` (the planner or perception raised, or the planner returned an invalid
candidate: NaN, not a rotation...) and `no_grasp` (the planner ran, but returned fewer
candidates than the group asked for, so this trial has no grasp to try: an object too
wide for the jaw). Stores written before `no_grasp` existed hold such trials as
`planner_error` with the detail "planner returned N of M requested candidates";
`TrialResult.from_flat` reads them as `no_grasp` (the detail text is the worker's, and
no other status carries it), so an old run reports like a new one; the stored rows (and
`manigrasp export` of them, which copies the rows) are not rewritten.
"""

from __future__ import annotations

import math
import re
from dataclasses import asdict, dataclass, field
from enum import StrEnum

import numpy as np
from scipy.spatial.transform import Rotation


class Status(StrEnum):
    """Outcome of one trial (DESIGN.md, "The standard protocol").

    `PLANNER_ERROR`: the planner (or the perception before it) failed: it raised or crashed its worker,
    or returned an invalid candidate (a planner call that overran its budget is `TIMEOUT`). `NO_GRASP`:
    the planner found no grasp to try for this trial (it returned fewer candidates than requested; the
    module docstring). Both are failures of the planner: they count in every success rate's denominator,
    and were never simulated.
    """

    SUCCESS = "success"
    PREGRASP_COLLISION = "pregrasp_collision"
    NO_CONTACT = "no_contact"
    SLIPPED_LIFT = "slipped_lift"
    DROPPED_PERTURB = "dropped_perturb"
    UNSTABLE = "unstable"
    PLANNER_ERROR = "planner_error"
    NO_GRASP = "no_grasp"
    INVALID_GRASP = "invalid_grasp"
    TIMEOUT = "timeout"
    HARNESS_FAULT = "harness_fault"


PLANNER_FAILURES = frozenset({Status.PLANNER_ERROR, Status.NO_GRASP})
"""The statuses of a trial that failed in the planner, before any grasp was executed (`Status`)."""

PERCEPTION_FAILED = "perception failed"
"""How the detail of a `Status.PLANNER_ERROR` trial begins when its group's pose estimate or point cloud failed (the
object not in view, no model fits): the report counts such estimates (`manigrasp.bench.report.PoseErrors.failed`)."""


class Phase(StrEnum):
    """A phase of a trial (`manigrasp.protocol.phases`; `TrialRun.phase` runs one).

    The values are what the results store holds in ``last_phase`` and what an observer's
    `on_phase` receives. `HOLD` runs inside `LIFT` and never ends up as a trial's `last_phase`.
    """

    SETTLE = "settle"
    PREGRASP = "pregrasp"
    APPROACH = "approach"
    CLOSE = "close"
    LIFT = "lift"
    HOLD = "hold"
    PERTURB = "perturb"
    SHAKE = "shake"

    @property
    def grasped(self) -> bool:
        """Whether the hand has closed on the object when this phase begins (lift, hold, perturb, shake)."""
        return self in (Phase.LIFT, Phase.HOLD, Phase.PERTURB, Phase.SHAKE)


DIRECTIONS = ("+x", "-x", "+y", "-y", "+z", "-z")
"""Names of the perturbation directions (world axes), as `TrialResult.perturb_direction` holds them."""


@dataclass(frozen=True)
class GraspMetrics:
    """Analytic quality of a set of contacts (NaN where not computed or undefined).

    Attributes:
        n_contacts: number of contacts the metrics were computed on.
        force_closure: 1.0 / 0.0, NaN when not computed.
        epsilon_l1: Ferrari-Canny epsilon with the L1 wrench set (0 without closure).
        min_friction: smallest friction coefficient giving force closure (inf: never).
    """

    n_contacts: int = 0
    force_closure: float = math.nan
    epsilon_l1: float = math.nan
    min_friction: float = math.nan


@dataclass(frozen=True)
class PoseRecord:
    """A rigid pose as stored with a trial: position [m] and unit quaternion (w, x, y, z); NaN: unknown."""

    x_m: float = math.nan
    y_m: float = math.nan
    z_m: float = math.nan
    qw: float = math.nan
    qx: float = math.nan
    qy: float = math.nan
    qz: float = math.nan

    @classmethod
    def of(cls, pose: np.ndarray) -> PoseRecord:
        """The record of a (4, 4) pose (NaN if it is not a finite rigid transform)."""
        pose = np.asarray(pose, dtype=float)
        if pose.shape != (4, 4) or not np.all(np.isfinite(pose)):
            return cls()
        try:
            quat = Rotation.from_matrix(pose[:3, :3]).as_quat(scalar_first=True)
        except ValueError:
            return cls(*(float(v) for v in pose[:3, 3]))
        quat = quat if quat[0] >= 0 else -quat  # one sign per rotation
        return cls(*(float(v) for v in pose[:3, 3]), *(float(v) for v in quat))

    def matrix(self) -> np.ndarray:
        """The (4, 4) pose (raises ValueError if any field is NaN)."""
        values = np.array([self.x_m, self.y_m, self.z_m, self.qw, self.qx, self.qy, self.qz])
        if not np.all(np.isfinite(values)):
            raise ValueError("the stored pose is incomplete (NaN)")
        out = np.eye(4)
        out[:3, :3] = Rotation.from_quat(values[3:], scalar_first=True).as_matrix()
        out[:3, 3] = values[:3]
        return out


def short_plan_detail(returned: int, requested: int) -> str:
    """The detail of a `no_grasp` trial: how many candidates the planner returned of how many requested."""
    return f"planner returned {returned} of {requested} requested candidates"


_SHORT_PLAN = re.compile(r"planner returned \d+ of \d+ requested candidates")  # `short_plan_detail`'s text

# Nested records of a trial, flattened as <prefix>_<field> columns.
_NESTED = (("planned", "planned"), ("sim", "simulated"), ("grasp", "grasp"), ("object", "object_pose"),
           ("rest", "rest_pose"))


@dataclass(frozen=True)
class TrialResult:
    """One trial's outcome.

    Attributes:
        status: success or the failure mode.
        detail: more about the status: what moved how far in the hand, the message of a planner error.
        last_phase: the last phase passed, a `Phase` ("" if none).
        perturb_direction: the perturbation direction (one of `DIRECTIONS`) in force when a trial failed
            as `dropped_perturb`; "" otherwise (a failure under `shake`, or after the perturbation ended).
        max_translation_m: largest displacement of the object relative to the hand after closing [m].
        max_rotation_deg: largest rotation of the object relative to the hand after closing [deg].
        fingers_in_contact: finger bodies touching the object at the end.
        grip_force_n: grip force after closing [N] (normal forces summed over contacts / 2 for two jaws).
        planned: metrics of the planner's contacts.
        simulated: metrics of the contacts the simulation produced after closing.
        score: the planner's score of this candidate (NaN if none).
        planning_time_s: the planner's time for this candidate [s].
        sim_steps: physics steps simulated.
        sim_time_s: simulated time [s].
        wall_time_s: wall-clock time of the trial [s] (the only non-reproducible field).
        seed: the trial's seed.
        pose_rotation_error_deg: rotation error of the pose the planner was given [deg]
            (observation "estimated_pose"; NaN otherwise).
        pose_translation_error_mm: translation error of that pose [mm] (NaN if not estimated).
        pose_add_s_mm: ADD-S of that pose [mm] (NaN if not estimated).
        pose_add_mm: ADD of that pose [mm] (NaN if not estimated, or stored before this column existed).
        pose_symmetric: 1.0 if the estimated object has a symmetry, so that its pose is judged by ADD-S
            (`manigrasp.perception.metrics.pose_good`), 0.0 if not; NaN if not estimated, or stored before this
            column existed.
        grasp: the executed grasp's TCP pose in the world (flattened as ``grasp_*`` columns).
        grasp_width_m: the planned jaw opening [m] (NaN: none given).
        grasp_joints: the grasp's own hand path (`GraspCandidate.joints`, (2, n_act) actuator commands) as
            JSON text ``[[pre-shape...], [squeeze...]]``; "" when the grasp used the hand's own path.
        grasp_preshape: the grasp's pre-shape synergy in [0, 1].
        object_pose: the object's settled pose in the world that the grasp was planned on
            (``object_*`` columns): with `grasp`, the grasp in the object's frame.
        plan_time_s: wall time of the whole planning call that produced this trial's candidate
            (one call per object x hand x planner x observation) [s]; `planning_time_s` is
            that time divided by the number of candidates.
        camera_views, camera_azimuth_deg, camera_elevation_deg, camera_distance_m, camera_noise_sigma_m: the
            cameras of a perception observation (`manigrasp.perception.setup.CameraSetup.record`: number, first
            camera's azimuth [deg], elevation [deg], distance [m], the depth noise's standard deviation at
            that distance [m]); 0 and NaN for ground truth.
        rest_index, rest_probability, rest_pose: the resting pose the object was placed in before it settled
            (`manigrasp.sim.config.SceneConfig.rest`): its rank among the object's stable poses (0: the most
            probable; -1: the orientation of its file), its quasi-static probability (NaN for the file's),
            and the pose itself (``rest_*`` columns: rotation as a quaternion, height of the object frame
            above the table as z [m], at x = y = 0).
    """

    status: Status
    detail: str = ""
    last_phase: str = ""
    perturb_direction: str = ""
    max_translation_m: float = math.nan
    max_rotation_deg: float = math.nan
    fingers_in_contact: tuple[str, ...] = ()
    grip_force_n: float = math.nan
    planned: GraspMetrics = field(default_factory=GraspMetrics)
    simulated: GraspMetrics = field(default_factory=GraspMetrics)
    score: float = math.nan
    planning_time_s: float = math.nan
    sim_steps: int = 0
    sim_time_s: float = 0.0
    wall_time_s: float = math.nan
    seed: int = 0
    pose_rotation_error_deg: float = math.nan
    pose_translation_error_mm: float = math.nan
    pose_add_s_mm: float = math.nan
    pose_add_mm: float = math.nan
    pose_symmetric: float = math.nan
    grasp: PoseRecord = field(default_factory=PoseRecord)
    grasp_width_m: float = math.nan
    grasp_joints: str = ""
    grasp_preshape: float = math.nan
    object_pose: PoseRecord = field(default_factory=PoseRecord)
    plan_time_s: float = math.nan
    camera_views: int = 0
    camera_azimuth_deg: float = math.nan
    camera_elevation_deg: float = math.nan
    camera_distance_m: float = math.nan
    camera_noise_sigma_m: float = math.nan
    rest_index: int = -1
    rest_probability: float = math.nan
    rest_pose: PoseRecord = field(default_factory=PoseRecord)

    @property
    def success(self) -> bool:
        """Whether the trial passed."""
        return self.status is Status.SUCCESS

    def flat(self) -> dict[str, object]:
        """A flat dict (metrics prefixed planned_/sim_, poses grasp_/object_) for tables and the results store."""
        row = asdict(self)
        row["status"] = self.status.value
        row["last_phase"] = str(self.last_phase)
        row["fingers_in_contact"] = ",".join(self.fingers_in_contact)
        for prefix, key in _NESTED:
            for name, value in row.pop(key).items():
                row[f"{prefix}_{name}"] = value
        return row

    @classmethod
    def from_flat(cls, row: dict[str, object]) -> TrialResult:
        """Inverse of `flat`. A row stored before `perturb_direction` existed (absent or not a string) gets
        the direction its `detail` began with ("+x: object moved ..."), as it was written then; one stored
        before `no_grasp` existed as `planner_error` with the detail `short_plan_detail` writes is read as
        `no_grasp` (module docstring). An integer field read as NaN (a column the store added after the row was
        written, NULL) takes its default."""
        row = dict(row)
        if row.get("status") == Status.PLANNER_ERROR.value and _SHORT_PLAN.fullmatch(str(row.get("detail") or "")):
            row["status"] = Status.NO_GRASP.value
        phase = str(row.pop("last_phase", "") or "")
        row["last_phase"] = Phase(phase) if phase in {p.value for p in Phase} else phase
        direction = row.get("perturb_direction")
        if not isinstance(direction, str):
            head = str(row.get("detail") or "").split(":")[0].strip()
            dropped = row.get("status") == Status.DROPPED_PERTURB.value
            row["perturb_direction"] = head if dropped and head in DIRECTIONS else ""
        metrics: dict[str, object] = {}
        for prefix, key in _NESTED:
            kind = TrialResult.__dataclass_fields__[key].default_factory  # type: ignore[misc]
            metrics[key] = kind(**{n: row.pop(f"{prefix}_{n}", math.nan) for n in kind.__dataclass_fields__})
        for name, spec in cls.__dataclass_fields__.items():  # an int column added since the row was stored: NULL
            value = row.get(name)
            if spec.type in ("int", int) and isinstance(value, float) and math.isnan(value):
                row[name] = spec.default
        fingers = str(row.pop("fingers_in_contact") or "")
        return cls(status=Status(row.pop("status")), fingers_in_contact=tuple(f for f in fingers.split(",") if f),
                   **metrics, **row)  # type: ignore[arg-type]
