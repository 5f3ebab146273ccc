"""Replaying stored trials: the same status from the stored grasp and seed, and recording after the fact."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from manigrasp.bench.config import parse_config
from manigrasp.bench.replay import ReplayError, record_trials, replay_trial, stored_trials
from manigrasp.bench.runner import run_benchmark
from manigrasp.cli import main
from manigrasp.protocol.result import Status


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("replay") / "run"
    config = {"objects": ["004_sugar_box"], "planners": ["antipodal", "random"], "grasps_per_object": 2,
              "protocol": "lift"}
    run_benchmark(parse_config(config), out, progress=False)
    return out


@pytest.mark.slow
def test_every_replayed_trial_ends_with_its_stored_status(run_dir):
    trials = stored_trials(run_dir)
    assert len(trials) == 4
    statuses = set()
    for trial_id in trials:
        replay = replay_trial(run_dir, trial_id)
        assert replay.same_status, (trial_id, replay.stored.status, replay.replayed.status, replay.replayed.detail)
        assert replay.object_pose_error < 1e-9 and replay.replayed.seed == replay.stored.seed
        statuses.add(replay.stored.status)
    assert Status.SUCCESS in statuses and len(statuses) > 1  # both outcomes are replayed


@pytest.mark.slow
def test_replay_cli_records_and_exits_zero_when_the_status_agrees(run_dir, tmp_path, capsys):
    trial_id = sorted(stored_trials(run_dir))[0]
    rrd = tmp_path / "trial.rrd"
    assert main(["replay", str(run_dir), trial_id, "--record", str(rrd)]) == 0
    assert rrd.is_file() and rrd.stat().st_size > 0
    assert f"{trial_id}: stored" in capsys.readouterr().out


def test_unknown_trial_names_the_closest(run_dir):
    trial_id = sorted(stored_trials(run_dir))[0]
    with pytest.raises(ReplayError, match="closest: .*" + re.escape(trial_id)):
        replay_trial(run_dir, trial_id[:-1] + "9")


def test_record_failures_of_a_finished_run(run_dir, tmp_path):
    from manigrasp.record.policy import trial_file_name

    failures = {t for t, s in stored_trials(run_dir).items() if s.result.status is not Status.SUCCESS}
    done = record_trials(run_dir, "failures", directory=tmp_path / "rec")
    assert {r.trial_id for r in done.replays} == failures and all(r.same_status for r in done.replays)
    assert done.skipped == ()
    assert sorted(p.name for p in (tmp_path / "rec").iterdir()) == sorted(trial_file_name(t) for t in failures)
    again = record_trials(run_dir, "failures", directory=tmp_path / "rec")  # nothing re-simulated twice
    assert again.replays == () and {t for t, _ in again.skipped} == failures


@pytest.mark.slow
def test_a_trial_that_executed_no_grasp_is_not_replayed_and_says_why(tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(Path(__file__).parent))
    config = {"objects": ["004_sugar_box"], "planners": ["faulty_planners:Raises"], "grasps_per_object": 1,
              "protocol": "lift"}
    run_benchmark(parse_config(config), tmp_path / "run", progress=False)
    (trial_id,) = stored_trials(tmp_path / "run")
    with pytest.raises(ReplayError, match="executed no grasp"):
        replay_trial(tmp_path / "run", trial_id)
    done = record_trials(tmp_path / "run", "all")
    assert done.replays == () and done.skipped == ((trial_id, "no grasp was executed (planner_error)"),)


@pytest.mark.slow
def test_a_file_planner_trial_replays_with_its_stored_detail(tmp_path):
    """A `file` planner's trial details begin with "file grasp j" (its grasp's index in the file); the replay rebuilt
    the candidate without that `source`, so its detail lacked it and differed from the stored one."""
    import json

    top = [[-1.0, 0, 0, 0], [0, 1, 0, 0], [0, 0, -1, 0.0875 - 0.015], [0, 0, 0, 1]]  # down across the box's top
    beside = [row[:] for row in top]
    beside[0][3] = 0.15  # 15 cm to the side: closes on nothing
    path = tmp_path / "sugar.json"
    path.write_text(json.dumps({"hand": "parallel_jaw", "object": {"name": "004_sugar_box"}, "grasps": [
        {"pose": beside, "score": 1.0}, {"pose": top, "width": 0.038, "score": 2.0}]}))
    config = {"objects": ["004_sugar_box"], "planners": [{"name": "file", "params": {"path": str(path)}}],
              "grasps_per_object": 2, "protocol": "lift"}
    run_benchmark(parse_config(config), tmp_path / "run", progress=False)
    trials = stored_trials(tmp_path / "run")
    assert sorted(t.result.detail.split(":")[0] for t in trials.values()) == ["file grasp 0", "file grasp 1"]
    for trial_id in trials:
        replay = replay_trial(tmp_path / "run", trial_id)
        assert replay.same_status and replay.replayed.detail == replay.stored.detail, (
            trial_id, replay.stored.detail, replay.replayed.detail)


def test_replay_help_names_the_default_base_the_code_uses(capsys):
    """`replay --help` said relative mesh paths default to the working directory; the code takes the config
    file's folder that run.json records (`stored_trials`: ``base or config_dir(run_dir)``)."""
    with pytest.raises(SystemExit):
        main(["replay", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "(default: working directory)" not in text and "the config file's folder, as run.json records it" in text
