"""`execute`: the frame around every protocol's phases (validation, settle, faults, the result)."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

from manigrasp.errors import SimulationError
from manigrasp.protocol.execution import Abort, GraspParams, TrialRun
from manigrasp.protocol.grasp import Grasp, as_grasp, check_grasp, grasp_tcp_pose
from manigrasp.protocol.metrics import planned_metrics
from manigrasp.protocol.observer import TrialObserver
from manigrasp.protocol.phases import release_hold
from manigrasp.protocol.result import GraspMetrics, Phase, Status, TrialResult
from manigrasp.protocol.settle import settle_object
from manigrasp.sim import Scene

Body = Callable[[TrialRun, np.ndarray, np.ndarray, Grasp], tuple[str, ...]]
"""A protocol's phases: (run, grasp pose (4, 4), object rest pose (4, 4), grasp) -> fingers touching at the end.
It returns only on success and raises `Abort` for every failure."""


SHORT_APPROACH_STATUSES = frozenset({Status.NO_CONTACT, Status.SLIPPED_LIFT, Status.DROPPED_PERTURB})
"""The failures whose detail ends with where a short approach stopped (`phases.approach_shortfall`): the hand
closed there, not at the grasp pose, which may be why it missed or held badly."""


def execute(scene: Scene, grasp: Any, params: GraspParams, body: Body, deadline: float | None,
            object_pose: np.ndarray | None, seed: int, clock: Callable[[], float] = time.monotonic,
            observer: TrialObserver | None = None) -> TrialResult:
    """Run `body` as one trial and turn its outcome, or its `Abort`, into a `TrialResult`.

    An invalid grasp (`grasp.check_grasp`: non-finite pose, non-rigid rotation, non-unit quaternion,
    pre-shape outside [0, 1], joints that do not fit the hand) is `invalid_grasp` before anything is
    simulated; the grasp's own hand path (`Grasp.joints`) is the scene's during the trial only;
    a `SimulationError` inside the trial is `unstable`. The scene is left with the hand's own gains and path.

    `observer` (or None) gets `on_start` first (with the given object pose, or, when the
    trial settles the object itself, the pose it is dropped from; "settle" is then the
    first phase), then the phases and samples, and `on_end` with the result.
    """
    start = time.perf_counter()
    try:
        grasp = as_grasp(grasp)
    except (TypeError, ValueError) as exc:  # a grasp whose fields are not numbers: the trial's input fault
        return TrialResult(Status.INVALID_GRASP, detail=f"grasp cannot be read: {exc}"[:500],
                           wall_time_s=time.perf_counter() - start, seed=seed)
    if observer is not None:
        dropped = scene.object_rest_pose() if object_pose is None else np.asarray(object_pose, float)
        observer.on_start(scene, grasp, dropped)
    problem = check_grasp(grasp, scene.hand, scene.hand_ctrlrange())
    if problem is not None:
        result = TrialResult(Status.INVALID_GRASP, detail=problem, planning_time_s=grasp.planning_time_s,
                             wall_time_s=time.perf_counter() - start, seed=seed)
        if observer is not None:
            observer.on_end(scene, result)
        return result
    run = TrialRun(scene, params, deadline, clock, observer)
    run.use_grasp(grasp)
    status, detail, fingers, planned = Status.SUCCESS, "", (), GraspMetrics()
    try:
        with run.phase(Phase.SETTLE, announce=object_pose is None):  # a given pose was settled by the caller
            if object_pose is None:
                rest = settle_object(scene, sampler=run.sampler)
                run.time0 = scene.time
            else:
                rest = np.asarray(object_pose, float)
        pose = grasp_tcp_pose(grasp)
        center = (rest @ np.append(scene.model.body_ipos[scene.object_body], 1.0))[:3]
        planned = grasp.planned_metrics or planned_metrics(scene, grasp.contacts, grasp.contact_normals, center,
                                                           run.torque_scale, params.metric_edges,
                                                           params.metric_friction_tol, grasp.contact_friction)
        fingers = body(run, pose, rest, grasp)
    except Abort as abort:
        status, detail = abort.status, abort.detail
        if run.approach_note and status in SHORT_APPROACH_STATUSES:  # it closed where it stopped, not at the grasp
            detail = f"{detail} ({run.approach_note})"
        fingers = _fingers_now(run)
    except SimulationError as exc:
        status, detail = Status.UNSTABLE, str(exc)
    finally:
        release_hold(run)  # the hand's own gains (a held grasp stiffens them) and path for whatever uses the
        scene.set_hand_path()  # scene next (the protocols release before a reset already; user code may not)
    dt = float(scene.model.opt.timestep)
    result = TrialResult(status=status, detail=detail, last_phase=run.last_phase,
                       perturb_direction=_perturb_direction(run, status),
                       max_translation_m=run.max_translation, max_rotation_deg=run.max_rotation,
                       fingers_in_contact=tuple(fingers), grip_force_n=run.grip_force_n, planned=planned,
                       simulated=run.simulated, planning_time_s=grasp.planning_time_s, sim_steps=run.steps,
                       sim_time_s=run.steps * dt, wall_time_s=time.perf_counter() - start, seed=seed)
    if observer is not None:
        observer.on_end(scene, result)
    return result


def _perturb_direction(run: TrialRun, status: Status) -> str:
    """The direction of the perturbation a `dropped_perturb` trial failed under ("" if none: a shake)."""
    phase, detail = run.stopped_in or (None, "")
    return detail if status is Status.DROPPED_PERTURB and phase is Phase.PERTURB else ""


def _fingers_now(run: TrialRun) -> tuple[str, ...]:
    """Fingers touching the object in the state the trial ended in (none if that state is not finite)."""
    if run.steps == 0 or not run.scene.is_finite():
        return ()
    return run.fingers_touching()
