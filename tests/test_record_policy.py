"""Which trials are recorded, where their files go, plan recordings, and `manigrasp view` headless."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from manigrasp.bench.recordings import select_recordings
from manigrasp.cli import main
from manigrasp.errors import ConfigError
from manigrasp.protocol import Status, TrialResult
from manigrasp.protocol.observer import NullObserver
from manigrasp.record import TrialRecorder
from manigrasp.record.policy import (
    RecordingWarning,
    RecordPolicy,
    RecordSettings,
    TrialRecording,
    should_record,
    trial_file_name,
    trial_recording,
)
from manigrasp.record.readback import summarize
from manigrasp.record.view import open_viewer
from tests.helpers import drive

TRIAL = "box_rec/parallel_jaw/antipodal/ground_truth/standard/0003"


@pytest.fixture(scope="module")
def box(box_scene) -> tuple:
    """The shared cube scene (conftest) and the cube's settled pose."""
    return box_scene.scene, box_scene.rest


@pytest.mark.parametrize(("text", "expected"), [
    ("none", RecordPolicy("none")), ("failures", RecordPolicy("failures")), ("ALL", RecordPolicy("all")),
    ("5", RecordPolicy("first", 5)), (2, RecordPolicy("first", 2))])
def test_policy_parses_the_cli_values(text: str, expected: RecordPolicy) -> None:
    assert RecordPolicy.parse(text) == expected


def test_unknown_policy_lists_the_choices() -> None:
    with pytest.raises(ConfigError, match="none, failures, successes, all or a count N"):
        RecordPolicy.parse("fails")


def test_should_record_before_and_after_the_trial() -> None:
    success, dropped = TrialResult(Status.SUCCESS), TrialResult(Status.DROPPED_PERTURB)
    assert not should_record("none", 0)
    assert should_record("failures", 7) and should_record("failures", 7, dropped)
    assert not should_record("failures", 7, success)
    assert should_record("successes", 0, success) and not should_record("successes", 0, dropped)
    assert should_record("2", 1, dropped) and should_record("2", 1, success) and not should_record("2", 2)
    assert should_record("all", 10**6, success)
    assert RecordSettings.for_run("run", "none") is None and RecordSettings.for_run("run", "0") is None


def test_trial_file_names_are_safe_and_distinct() -> None:
    assert trial_file_name(TRIAL) == "box_rec__parallel_jaw__antipodal__ground_truth__standard__0003.rrd"
    odd = trial_file_name("my.pkg:planner/hand x/0001")
    assert "/" not in odd and ":" not in odd and " " not in odd and odd.endswith(".rrd")
    assert trial_file_name("a:b/0001") != trial_file_name("a_b/0001")


def _record(scene_rest: tuple, tmp_path: Path, policy: str, index: int, status: Status) -> TrialRecording:
    scene, rest = scene_rest
    settings = RecordSettings.for_run(tmp_path, policy)
    with trial_recording(settings, TRIAL, index) as rec:
        drive(scene, rec.observer, rest, seconds=0.1)
        rec.finish(TrialResult(status))
    return rec


def test_failures_policy_keeps_failures_and_drops_successes(box, tmp_path: Path) -> None:  # noqa: ANN001
    kept = _record(box, tmp_path / "a", "failures", 0, Status.SLIPPED_LIFT)
    assert kept.path == tmp_path / "a" / "recordings" / trial_file_name(TRIAL) and kept.path.is_file()
    assert summarize(kept.path).recording_id == TRIAL
    dropped = _record(box, tmp_path / "b", "failures", 0, Status.SUCCESS)
    assert dropped.path is None and list((tmp_path / "b" / "recordings").iterdir()) == []  # no .partial left


def test_first_n_policy_records_only_the_first_trials(box, tmp_path: Path) -> None:  # noqa: ANN001
    late = _record(box, tmp_path, "2", 2, Status.SUCCESS)
    assert isinstance(late.observer, NullObserver) and late.path is None
    assert _record(box, tmp_path, "2", 1, Status.SUCCESS).path.is_file()


def test_a_trial_that_raises_counts_as_unstable(box, tmp_path: Path) -> None:  # noqa: ANN001
    scene, rest = box
    settings = RecordSettings.for_run(tmp_path, "failures")
    with pytest.raises(ValueError, match="boom"), trial_recording(settings, TRIAL, 0) as rec:
        rec.observer.on_start(scene, np.eye(4), rest)
        raise ValueError("boom")
    assert rec.path is not None and summarize(rec.path).status == "unstable"


def test_a_broken_recording_warns_and_is_dropped(box, tmp_path: Path, monkeypatch) -> None:  # noqa: ANN001
    scene, rest = box

    def broken(self, scene, t):  # noqa: ANN001, ANN202, ARG001
        raise RuntimeError("disk full")

    monkeypatch.setattr(TrialRecorder, "_sample", broken)
    settings = RecordSettings.for_run(tmp_path, "all")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with trial_recording(settings, TRIAL, 0) as rec:
            drive(scene, rec.observer, rest, seconds=0.05)
    assert rec.path is None and any(issubclass(w.category, RecordingWarning) for w in caught)
    assert list((tmp_path / "recordings").iterdir()) == []


def test_view_headless_prints_the_command_and_never_fails(box, tmp_path: Path, capsys,  # noqa: ANN001
                                                          monkeypatch) -> None:
    _record(box, tmp_path, "all", 0, Status.DROPPED_PERTURB)
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr("sys.platform", "linux")
    assert main(["view", str(tmp_path), "--status", "dropped_perturb"]) == 0
    out = capsys.readouterr().out
    assert "no display" in out and "rerun" in out and trial_file_name(TRIAL) in out
    assert main(["view", str(tmp_path), "--trial", TRIAL]) == 0
    outcome = open_viewer(select_recordings(tmp_path), display=False)
    assert not outcome.opened and outcome.command.endswith(trial_file_name(TRIAL))


def test_view_user_mistakes_are_clear_errors(box, tmp_path: Path, capsys) -> None:  # noqa: ANN001
    _record(box, tmp_path, "all", 0, Status.SUCCESS)
    assert main(["view", str(tmp_path), "--status", "dropped"]) == 2
    assert "available: success" in capsys.readouterr().err
    assert main(["view", str(tmp_path), "--status", "no_contact"]) == 2
    assert main(["view", str(tmp_path / "missing")]) == 2


def test_plan_recording_holds_object_and_candidates_coloured_by_score(box_asset, tmp_path: Path) -> None:  # noqa: ANN001
    from manigrasp import hands, planners
    from manigrasp.record.plan import record_plan, score_colors

    observation = planners.Observation.from_asset(box_asset)
    result = planners.plan(planners.load("antipodal"), observation, hands.load("parallel_jaw"), 10,
                           np.random.default_rng(0))
    path = record_plan(tmp_path / "plan.rrd", observation, result.candidates, title="antipodal on box")
    summary = summarize(path)
    assert {"/world/object", "/world/candidates", "/world/candidates/tcp", "/plan"} <= set(summary.entities)
    colors = score_colors(np.array([3.0, 2.0, 1.0]))
    assert tuple(colors[0, :3]) == (40, 190, 70) and tuple(colors[-1, :3]) == (220, 40, 40)  # best green, worst red
    assert colors.shape == (3, 4) and colors.dtype == np.uint8


def test_settings_travel_to_worker_processes(tmp_path: Path) -> None:
    import pickle

    settings = RecordSettings.for_run(tmp_path, "3")
    assert pickle.loads(pickle.dumps(settings)) == settings
