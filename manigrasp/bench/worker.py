"""What runs inside a worker process: plan one group, run one trial.

Each worker keeps its compiled scenes (one per object x hand x physics) and
reuses them across trials by resetting state, never recompiling per grasp.
Every failure inside a trial becomes that trial's status, and every failure of
a group's planning (settling, observing, the planner) that group's: a
perception failure or a planner's exception (or invalid candidate) is
`planner_error`, anything else (a harness bug) is `harness_fault` with the
traceback's last lines in `detail`, never a physics status. A planner that
returns fewer candidates than requested leaves its last trials without a
grasp: they are `no_grasp` ("planner returned 3 of 20 requested candidates").
The process pool (`manigrasp.bench.pool`) adds the hard wall-clock budgets: it
hears `timed_start` and ends a worker that overruns.
"""

from __future__ import annotations

import math
import time
import traceback
from dataclasses import dataclass, replace

import numpy as np

from manigrasp.bench.observe import ObservationInfo, observe_with_info
from manigrasp.bench.store import TrialKey, joints_text
from manigrasp.bench.trials import Group
from manigrasp.errors import ManigraspError, PerceptionError
from manigrasp.protocol.result import PERCEPTION_FAILED, PoseRecord, Status, TrialResult, short_plan_detail
from manigrasp.record.policy import trial_recording

_SCENES: dict[tuple, object] = {}
_ASSETS: dict[str, object] = {}
_ON_TIMED_START: list = []  # callbacks of the hosting pool process (`manigrasp.bench.pool`)


def timed_start() -> None:
    """Tell the hosting pool that the budgeted part of a task (planner call, protocol run) starts now."""
    for callback in _ON_TIMED_START:
        callback()


def fault_detail(exc: BaseException, limit: int = 800) -> str:
    """`Type: message` and the last lines of the traceback, for a result's `detail`."""
    lines = traceback.format_exception(exc)
    tail = "".join(lines[-4:]).strip().replace("\n", " | ")
    return f"{type(exc).__name__}: {exc} | {tail}"[:limit]


@dataclass(frozen=True)
class Plan:
    """A group's planning outcome: candidates (best first) or the planner's error.

    Attributes:
        candidates: the planner's candidates (may be fewer than requested).
        error: why planning failed (then `candidates` is empty), or None.
        planning_time_s: wall time of the planning call [s].
        object_pose: (4, 4) settled (true) object pose.
        observation: how the planner's observation was made and its pose errors.
        planned: the analytic metrics of each candidate's planned contacts, scored in one batch
            with the protocol's contact model (aligned with `candidates`).
        status: the status of every trial of the group when `error` is set (`planner_error` for the
            planner or perception, `harness_fault` for the harness, `timeout` for an overrun budget).
    """

    candidates: tuple
    error: str | None
    planning_time_s: float
    object_pose: np.ndarray
    observation: ObservationInfo
    planned: tuple = ()
    status: Status = Status.PLANNER_ERROR

    @classmethod
    def failed(cls, group: Group, status: Status, detail: str, seconds: float = math.nan) -> Plan:
        """A plan that failed before any candidate: every trial of the group gets `status` and `detail`."""
        return cls((), detail, seconds, np.full((4, 4), np.nan), ObservationInfo(group.observation), (), status)


def _asset(group: Group):
    from manigrasp.objects import catalog

    name = group.object_source.name
    if name not in _ASSETS:
        asset = catalog.build(group.object_source).asset
        built = asset.metadata.get("hull_key", "")
        if group.object_key and built != group.object_key:  # a harness fault of the group or trial, not physics
            from manigrasp.errors import MeshError

            raise MeshError(f"object {name}: this worker's build differs from the run's (built as {built[:12]}, the "
                            f"run's {group.object_key[:12]}): its mesh file edited during the run, or another "
                            "CoACD, trimesh or MeshFix version on this worker; a trial on it would be of another "
                            "object (an edited mesh: start a new --out)")
        _ASSETS[name] = asset
    return _ASSETS[name]


def scene_for(group: Group):
    """The worker's compiled scene for the group's object x hand x physics."""
    from manigrasp.sim import build_scene

    key = (group.object_source, group.hand, group.scene)
    if key not in _SCENES:
        _SCENES[key] = build_scene(group.hand, _asset(group), group.scene)
    return _SCENES[key]


def plan_group(group: Group) -> Plan:
    """Settle the object, observe it, and ask the group's planner for `n_grasps` candidates.

    Never raises for the group's fault: the failure is the returned plan's `status` and `error`.
    """
    from manigrasp import planners
    from manigrasp.planners.context import PlanContext
    from manigrasp.protocol import PROTOCOLS, settle_object

    start = time.perf_counter()
    stage = "setting up"
    try:
        scene = scene_for(group)
        context = PlanContext.for_run(PROTOCOLS.load(group.protocol.name, **dict(group.protocol.params)).params,
                                      group.scene, scene.hand)
        stage = "settling the object"
        pose = settle_object(scene)
        stage = "observing"
        observation, info = observe_with_info(group.observation, _asset(group), pose, scene, seed=group.seed,
                                              camera=group.camera)
        stage = "planning"
        planner = planners.load(group.planner.name, **dict(group.planner.params))
        start = time.perf_counter()
        timed_start()
        result = planners.plan(planner, observation, scene.hand, group.n_grasps, group.rng(), context=context)
        stage = "scoring the planned contacts"
        planned = _planned_metrics(group, scene, result.candidates, pose)
    except PerceptionError as exc:
        return Plan.failed(group, Status.PLANNER_ERROR, f"{PERCEPTION_FAILED}: {exc}"[:800])
    except ManigraspError as exc:  # planners.plan turns anything a planner raises into a PlannerError
        status = Status.PLANNER_ERROR if stage == "planning" else Status.HARNESS_FAULT
        detail = str(exc) if stage == "planning" else f"{stage}: {fault_detail(exc)}"
        seconds = time.perf_counter() - start if stage == "planning" else math.nan  # a setup time is no planning
        return Plan.failed(group, status, detail[:800], seconds)
    except Exception as exc:  # a harness bug in one group must not end the run: record it
        return Plan.failed(group, Status.HARNESS_FAULT, f"{stage}: {fault_detail(exc)}")
    return Plan(result.candidates, None, result.planning_time_s, pose, info, planned)


def _planned_metrics(group: Group, scene, candidates: tuple, object_pose: np.ndarray) -> tuple:
    from manigrasp.protocol import PROTOCOLS
    from manigrasp.protocol.metrics import planned_metrics_batch

    params = PROTOCOLS.load(group.protocol.name, **dict(group.protocol.params)).params
    grasps = [(c.contacts, c.contact_normals, c.contact_friction) for c in candidates]
    return tuple(planned_metrics_batch(scene, grasps, object_pose, params.torque_scale, params.metric_edges,
                                       params.metric_friction_tol))


def run_trial(group: Group, index: int, plan: Plan, record=None) -> tuple[TrialKey, TrialResult]:
    """Run trial `index` of `group` with its planned candidate; never raises for a trial's fault.

    `record` (`manigrasp.record.policy.RecordSettings` or None) says whether to write a rerun recording.
    """
    key, result = _run_trial(group, index, plan, record)
    info = plan.observation
    result = replace(result, pose_rotation_error_deg=info.rotation_error_deg,
                     pose_translation_error_mm=info.translation_error_mm, pose_add_s_mm=info.add_s_mm,
                     pose_add_mm=info.add_mm,
                     pose_symmetric=math.nan if info.symmetric is None else float(info.symmetric),
                     object_pose=PoseRecord.of(plan.object_pose), plan_time_s=plan.planning_time_s)
    camera = info.camera
    if camera is None and group.observation != "ground_truth":  # perception failed: the setup still applies
        from manigrasp.perception.setup import CameraSetup

        camera = group.camera or CameraSetup()
    if camera is not None:
        fields = camera.record()
        if group.observation == "estimated_pose":
            fields["camera_views"] = 1  # the one camera its pose estimate used (`trials` module docstring)
        result = replace(result, **fields)
    if index < len(plan.candidates):  # a GraspCandidate with numeric fields (planners.plan validated it)
        candidate = plan.candidates[index]
        result = replace(result, grasp=PoseRecord.of(candidate.pose), grasp_preshape=float(candidate.preshape),
                         grasp_width_m=math.nan if candidate.width is None else float(candidate.width),
                         grasp_joints=joints_text(candidate.joints))
    return key, replace(result, **_rest_record(group, plan))


def _rest_record(group: Group, plan: Plan) -> dict:
    """The trial's resting-pose fields (`TrialResult.rest_*`): the rank always, the probability and pose once the
    group's scene was built (a plan that failed may have failed building it)."""
    stable = group.scene.rest != "file"
    out: dict = {"rest_index": group.scene.rest_index if stable else -1}
    if plan.error is None:
        rest = scene_for(group).rest
        out.update(rest_probability=rest.probability if stable else math.nan, rest_pose=PoseRecord.of(rest.matrix()))
    return out


def as_stored(pose: np.ndarray) -> np.ndarray:
    """(4, 4) `pose` as the results store keeps it (position and unit quaternion, `PoseRecord`), so that a replay
    from the store executes the very same numbers as the run: a trial can be chaotic (3 of 10 mug trials with
    compliant pads changed status for the 2e-16 of a quaternion round trip). A pose that is not a rigid
    transform within 1e-12 is returned unchanged, for the protocol to refuse."""
    try:
        stored = PoseRecord.of(pose).matrix()
    except ValueError:
        return pose
    return stored if np.allclose(stored, pose, rtol=0.0, atol=1e-12) else pose


def with_source(source: str, detail: str) -> str:
    """A trial's `detail` beginning with its candidate's `source` ("file grasp 7: dropped_lift ..."), if any."""
    if not source:
        return detail
    return f"{source}: {detail}" if detail else source


def _run_trial(group: Group, index: int, plan: Plan, record) -> tuple[TrialKey, TrialResult]:
    key, seed = group.key(index), group.trial_seed(index)
    planning_time = plan.planning_time_s / max(1, len(plan.candidates))
    if plan.error is not None:
        return key, TrialResult(plan.status, detail=plan.error[:800], planning_time_s=planning_time, seed=seed)
    if index >= len(plan.candidates):
        detail = short_plan_detail(len(plan.candidates), group.n_grasps)
        return key, TrialResult(Status.NO_GRASP, detail=detail, planning_time_s=planning_time, seed=seed)
    from manigrasp.protocol import PROTOCOLS
    from manigrasp.protocol.grasp import as_grasp

    start = time.perf_counter()
    try:
        protocol = PROTOCOLS.load(group.protocol.name, **dict(group.protocol.params))
        grasp = as_grasp(replace(plan.candidates[index], pose=as_stored(plan.candidates[index].pose)))
        if plan.planned:
            grasp = replace(grasp, planned_metrics=plan.planned[index])
        scene = scene_for(group)
        timed_start()
        with trial_recording(record, key.trial_id, index, plan.candidates[index]) as recording:
            result = protocol.run(scene, grasp, np.random.default_rng(seed),
                                  deadline=time.monotonic() + group.timeout_s, object_pose=plan.object_pose,
                                  observer=recording.observer)
    except Exception as exc:  # protocols never raise for the trial's fault: this is the harness's
        result = TrialResult(Status.HARNESS_FAULT, detail=fault_detail(exc))
    candidate = plan.candidates[index]
    return key, replace(result, detail=with_source(candidate.source, result.detail), seed=seed,
                        planning_time_s=planning_time, score=float(candidate.score),
                        wall_time_s=time.perf_counter() - start if math.isnan(result.wall_time_s)
                        else result.wall_time_s)
