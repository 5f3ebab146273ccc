"""The progress bar's running success count is the count of the trials the bar has counted."""

from __future__ import annotations

from manigrasp.bench import runner
from manigrasp.bench.config import parse_config
from manigrasp.protocol.result import Status, TrialResult


class _Bar:
    """Records, at each step of the bar, the success count it would show with that step."""

    def __init__(self) -> None:
        self.postfix = ""
        self.shown: list[str] = []

    def update(self, n: int) -> None:
        self.shown.append(self.postfix)  # what tqdm draws on update: the postfix set so far

    def set_postfix_str(self, text: str, refresh: bool = True) -> None:
        self.postfix = text

    def close(self) -> None:
        pass


def _run_with(monkeypatch, outcomes, bar=None, ran=None):
    """The 3-grasp mug config, run with the trials' statuses taken from `outcomes` (by grasp index, or in the order
    the trials run if an iterator); `ran` collects the grasp indices run; a `bar` replaces the progress bar."""
    def tasks(pending, todo, jobs, address, settings):
        for group in pending:
            for i in todo[id(group)]:
                if ran is not None:
                    ran.append(i)
                status = next(outcomes) if hasattr(outcomes, "__next__") else outcomes[i]
                yield group.key(i), TrialResult(status, seed=group.trial_seed(i))

    monkeypatch.setattr(runner, "_iter_local", tasks)
    if bar is not None:
        monkeypatch.setattr(runner, "_progress_bar", lambda total, initial, enabled: bar)
    return parse_config({"objects": ["025_mug"], "planners": ["random"], "grasps_per_object": 3})


def test_each_step_of_the_bar_shows_the_successes_of_the_trials_it_counts(tmp_path, monkeypatch):
    """Trials 0, 1, 2 of the mug: success, failure, success. Before, the bar drew each step before it updated
    the count, so after 2 trials it read success=1/1 (and after the first, an empty count)."""
    bar = _Bar()
    config = _run_with(monkeypatch, [Status.SUCCESS, Status.NO_CONTACT, Status.SUCCESS], bar)
    summary = runner.run_benchmark(config, tmp_path / "run", progress=True)
    assert (summary.ran, summary.successes) == (3, 2)
    assert bar.shown == ["success=1/1", "success=1/2", "success=2/3"]
    # Resumed with trial 2 removed: the bar starts at 2 of 3 stored, and its count says it is this session's.
    import sqlite3

    with sqlite3.connect(tmp_path / "run" / "results.sqlite") as db:
        db.execute("DELETE FROM trials WHERE grasp_index = 2")
    bar.shown.clear()
    summary = runner.run_benchmark(config, tmp_path / "run", progress=True)
    assert (summary.already_done, summary.ran, summary.successes) == (2, 1, 1)
    assert bar.shown == ["success=1/1 this session"]


def test_the_bars_count_leaves_harness_faults_out_as_the_reports_do(tmp_path, monkeypatch):
    """Success, harness fault, failure: the bar read success=1/2 after the fault, a rate no report gives."""
    bar = _Bar()
    config = _run_with(monkeypatch, [Status.SUCCESS, Status.HARNESS_FAULT, Status.NO_CONTACT], bar)
    runner.run_benchmark(config, tmp_path / "run", progress=True)
    assert bar.shown == ["success=1/1", "success=1/1, 1 harness fault(s)", "success=1/2, 1 harness fault(s)"]


def test_a_resumed_run_runs_its_harness_faults_again_and_replaces_them(tmp_path, monkeypatch, capsys):
    """A trial stored as a harness fault (its worker killed from outside, say) was never run again: resumed, it is,
    and its row is replaced; the other stored trials are not run again, and nothing is stored twice."""
    import sqlite3

    ran = []
    config = _run_with(monkeypatch, iter([Status.SUCCESS, Status.HARNESS_FAULT, Status.NO_CONTACT, Status.SUCCESS]),
                       ran=ran)
    runner.run_benchmark(config, tmp_path / "run", progress=False)
    from manigrasp.record.policy import trial_file_name

    stale = tmp_path / "run" / "recordings" / trial_file_name(config_key(config, 1))
    stale.parent.mkdir()
    stale.write_bytes(b"a recording of the faulted attempt")  # (it was listed under the re-run's status)
    summary = runner.run_benchmark(config, tmp_path / "run", progress=False)
    assert ran == [0, 1, 2, 1] and (summary.already_done, summary.ran, summary.successes) == (2, 1, 1)
    assert "1 trial(s) stored as harness_fault run again" in capsys.readouterr().err
    with sqlite3.connect(tmp_path / "run" / "results.sqlite") as db:
        rows = dict(db.execute("SELECT grasp_index, status FROM trials").fetchall())
    assert rows == {0: "success", 1: "success", 2: "no_contact"}
    assert runner.run_benchmark(config, tmp_path / "run", progress=False).ran == 0
    assert not stale.exists()


def config_key(config, index: int) -> str:
    """The trial id of grasp `index` of the config's one group."""
    from manigrasp.bench.trials import groups

    (group,) = groups(config)
    return group.key(index).trial_id


def test_a_trial_that_overran_or_died_names_its_candidates_source_as_a_finished_one_does():
    """A `file` planner's trial begins its detail with "file grasp j" (its grasp's index in the file), but one
    whose worker overran its budget or died had only "trial ran over ...": the trials a user most needs to join
    back to the file."""
    import numpy as np

    from manigrasp.bench.pool import Outcome, Task
    from manigrasp.bench.trials import groups
    from manigrasp.bench.worker import Plan
    from manigrasp.planners.base import GraspCandidate

    config = parse_config({"objects": ["025_mug"], "planners": ["random"], "grasps_per_object": 2})
    (group,) = groups(config)
    candidates = tuple(GraspCandidate(pose=np.eye(4), score=1.0, source=f"file grasp {j}") for j in (7, 3))
    plan = Plan(candidates, None, 0.1, np.eye(4), None)

    class _Pool:
        def __init__(self) -> None:
            self.tasks: list[Task] = []

        def submit(self, task: Task, first: bool = False) -> None:
            self.tasks.append(task)

        def outcomes(self):
            yield Outcome(self.tasks[0], "done", value=plan)
            yield Outcome(self.tasks[1], "timeout", detail="ran over its 60 s budget")
            yield Outcome(self.tasks[2], "died", detail="worker died")

    results = dict(runner._run_tasks(_Pool(), [group], {id(group): [0, 1]}, None))
    details = {key.grasp_index: r.detail for key, r in results.items()}
    assert details[1] == "file grasp 3: trial ran over its 60 s budget"
    assert details[0] == "file grasp 7: trial worker died"


def test_a_run_whose_store_holds_trials_this_version_does_not_name_is_not_resumed(tmp_path, monkeypatch):
    """A YCB download's object was named as its folder (025_mug) and is now 025_mug_ycb: resumed, a run of the old
    naming accepted the config (run.json records the entry, not the name) and ran every trial again under the new
    name, the old ones kept (the report showed both, and Scan vs recipe paired the scan with itself)."""
    import pytest

    from manigrasp.bench.store import ResultsStore, TrialKey
    from manigrasp.errors import ConfigError

    config = _run_with(monkeypatch, [Status.SUCCESS, Status.NO_CONTACT, Status.SUCCESS])
    runner.run_benchmark(config, tmp_path / "run", progress=False)
    runner.run_benchmark(config, tmp_path / "run", progress=False)  # resumed as it is: nothing to refuse
    with ResultsStore(tmp_path / "run" / "results.sqlite") as store:  # a trial of a group named otherwise
        store.add(TrialKey("025_mug_old", "parallel_jaw", "random", "ground_truth", "standard", 0),
                  TrialResult(Status.SUCCESS))
    with pytest.raises(ConfigError, match="does not name for the run's config"):
        runner.run_benchmark(config, tmp_path / "run", progress=False)
