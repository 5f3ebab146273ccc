"""`no_grasp`: a trial the planner found no grasp for, told apart from a planner that failed (`planner_error`)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from manigrasp.bench import plots
from manigrasp.bench.config import NamedEntry
from manigrasp.bench.observe import ObservationInfo
from manigrasp.bench.replay import _executed_nothing
from manigrasp.bench.report import metric_aucs, summarize
from manigrasp.bench.store import ResultsStore, TrialKey
from manigrasp.bench.trials import Group
from manigrasp.bench.worker import Plan, plan_group, run_trial
from manigrasp.objects import catalog
from manigrasp.planners import GraspCandidate
from manigrasp.protocol.result import PLANNER_FAILURES, GraspMetrics, Status, TrialResult, short_plan_detail
from manigrasp.sim.config import SceneConfig


@pytest.fixture(autouse=True)
def _test_planners_importable(monkeypatch):
    monkeypatch.syspath_prepend(str(Path(__file__).parent))


class OneGrasp:
    """A planner that finds a single top-down grasp however many are asked for."""

    name = "one_grasp"
    needs = "mesh"

    def plan(self, observation, hand, n, rng):
        pose = np.diag([1.0, -1.0, -1.0, 1.0])
        pose[:3, 3] = observation.object_pose[:3, 3]
        return [GraspCandidate(pose=pose, score=1.0)]


def _group(planner: str, n: int = 3) -> Group:
    return Group(catalog.shipped("004_sugar_box"), "parallel_jaw", NamedEntry(planner), NamedEntry("lift"),
                 "ground_truth", SceneConfig(), n, seed=5, timeout_s=60.0)


def test_the_trials_a_planner_found_no_grasp_for_are_no_grasp_and_count_as_its_failures():
    group = _group("test_status_no_grasp:OneGrasp")
    plan = plan_group(group)
    assert plan.error is None and len(plan.candidates) == 1
    results = [run_trial(group, i, plan) for i in (1, 2)]  # grasp 0 exists (not simulated here)
    for (key, result), index in zip(results, (1, 2), strict=True):
        assert key.grasp_index == index and result.status is Status.NO_GRASP and not result.success
        assert result.detail == "planner returned 1 of 3 requested candidates"
        assert result.planning_time_s == plan.planning_time_s  # the call's time over its one candidate
        assert math.isnan(result.grasp.x_m) and _executed_nothing(result)
    simulated = TrialResult(Status.SUCCESS, planned=GraspMetrics(2, 1.0, 0.1, 0.3), score=1.0)
    report = summarize([(group.key(0), simulated), *results])
    rate = report.by_method[("parallel_jaw", "OneGrasp", "ground_truth", "lift")]
    assert (rate.trials, rate.successes, rate.failure_modes) == (3, 1, {"no_grasp": 2})  # in the denominator
    assert metric_aucs([simulated, *(r for _, r in results)])["epsilon_l1"].n == 1  # never simulated: no metric


def test_a_planner_that_raises_stays_a_planner_error():
    group = _group("faulty_planners:Raises", n=2)
    plan = plan_group(group)
    assert plan.status is Status.PLANNER_ERROR and "planner exploded" in plan.error
    key, result = run_trial(group, 1, plan)
    assert result.status is Status.PLANNER_ERROR and "planner exploded" in result.detail


def test_a_plan_with_no_candidate_leaves_every_trial_without_a_grasp():
    group = _group("antipodal", n=2)
    empty = Plan((), None, 0.4, np.eye(4), ObservationInfo("ground_truth"))
    for index in range(2):
        _, result = run_trial(group, index, empty)
        assert result.status is Status.NO_GRASP and result.detail == short_plan_detail(0, 2)
        assert result.detail == "planner returned 0 of 2 requested candidates"


def test_an_old_store_that_recorded_a_short_plan_as_planner_error_reads_it_as_no_grasp(tmp_path):
    old = {"short": TrialResult(Status.PLANNER_ERROR, detail="planner returned 0 of 20 requested candidates"),
           "raised": TrialResult(Status.PLANNER_ERROR, detail="planner 'x' raised RuntimeError: boom"),
           "nan": TrialResult(Status.PLANNER_ERROR, detail="planner 'x': candidate 0 is invalid: pose has NaN"),
           "quoted": TrialResult(Status.PLANNER_ERROR,
                                 detail="planner 'x' raised ValueError: planner returned 0 of 20 requested candidates")}
    with ResultsStore(tmp_path / "results.sqlite") as store:
        for i, result in enumerate(old.values()):
            store.add(TrialKey("025_mug", "parallel_jaw", "antipodal", "ground_truth", "standard", i), result)
        rows = list(store.rows())
        read = [r for _, r in store.results()]
    assert [r["status"] for r in rows] == ["planner_error"] * 4  # the stored rows are not rewritten
    assert [r.status for r in read] == [Status.NO_GRASP, Status.PLANNER_ERROR, Status.PLANNER_ERROR,
                                        Status.PLANNER_ERROR]
    assert [r.detail for r in read] == [r.detail for r in old.values()]
    assert TrialResult.from_flat(TrialResult(Status.NO_GRASP, detail="x").flat()).status is Status.NO_GRASP


def test_both_planner_failures_have_a_colour_of_their_own():
    assert PLANNER_FAILURES == {Status.PLANNER_ERROR, Status.NO_GRASP}
    colours = {plots.status_colour(s.value) for s in Status}
    assert len(colours) == len(Status) and plots.status_colour("no_grasp") != plots.status_colour("planner_error")
