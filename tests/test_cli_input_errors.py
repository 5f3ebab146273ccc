"""One-line errors for inputs a newcomer gets wrong (found by a CLI audit): nothing runs, nothing is written."""

from __future__ import annotations

import pytest

from manigrasp.cli import main
from manigrasp.errors import ConfigError
from manigrasp.perception.pipeline import CameraConfig


def _one_line_error(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    return err


@pytest.mark.parametrize("argv", [["label", "quick", "--jobs", "-2"], ["objects", "build", "mug", "--jobs", "0"]])
def test_jobs_below_one_is_refused_as_bench_refuses_it(argv, tmp_path, capsys):
    """label and objects build ran one job for --jobs -2 (max(1, jobs)), where bench and evaluate refuse it."""
    out = ["--out", str(tmp_path / "run")] if argv[0] == "label" else []
    assert main([*argv, *out]) == 2
    assert "--jobs must be >= 1" in _one_line_error(capsys)
    assert not (tmp_path / "run").exists()


def test_a_misspelled_scan_is_suggested_by_its_own_name(capsys):
    """The list of shipped names left the scans out: '003_cracker_box_scna' suggested the recipe twin."""
    assert main(["plan", "--object", "003_cracker_box_scna", "--hand", "parallel_jaw", "--planner", "random"]) == 2
    assert "did you mean '003_cracker_box_scan'?" in _one_line_error(capsys)


@pytest.mark.parametrize("name", ["part.obj", "scans/Part.STL", "/tmp/x/part"])
def test_a_mesh_path_given_as_an_object_name_points_at_the_mesh_option(name, capsys):
    """plan --object part.obj listed the shipped names only; a path is no object name, and --mesh takes it."""
    assert main(["plan", "--object", name, "--hand", "parallel_jaw", "--planner", "random"]) == 2
    err = _one_line_error(capsys)
    assert "is a path, not an object name" in err and f"plan --mesh {name}" in err


def test_a_run_without_recordings_names_replay_as_well(tmp_path, capsys):
    """view on an `evaluate` run advised re-running `bench CONFIG --record`, which evaluate has no config for."""
    (tmp_path / "run").mkdir()
    assert main(["view", str(tmp_path / "run")]) == 2
    err = _one_line_error(capsys)
    assert "has no recordings" in err and f"manigrasp replay {tmp_path / 'run'} TRIAL_ID --record" in err


def test_scale_is_refused_for_a_shipped_object(capsys):
    """plan --object mug --scale 2 planned on the real-size mug, ignoring --scale."""
    assert main(["plan", "--object", "mug", "--scale", "2", "--hand", "parallel_jaw", "--planner", "random"]) == 2
    assert "--scale applies to a --mesh file" in _one_line_error(capsys)


@pytest.mark.parametrize("fields", [{"distance": -1.0}, {"distance": 0.0}, {"fovy_deg": 0.0}, {"width": 0},
                                    {"elevation_deg": float("nan")}])
def test_a_camera_that_cannot_see_is_a_config_error(fields):
    """perceive --camera 30,45,-1 put the camera behind its target and reported 'object not in view'."""
    with pytest.raises(ConfigError, match="camera:"):
        CameraConfig(**fields)


def test_plan_json_holds_a_dexterous_grasps_preshape_and_hand_path():
    """`plan --json` left out the pre-shape and the planner's own hand path: a dexopt grasp could not be run
    again from it."""
    import json

    import numpy as np

    from manigrasp.cli.plan import candidate_record
    from manigrasp.planners.base import GraspCandidate

    path = np.array([[0.0, 0.1, 0.2], [0.5, 0.6, 0.7]])
    record = json.loads(json.dumps(candidate_record(GraspCandidate(np.eye(4), 1.0, preshape=0.25, joints=path))))
    assert record["preshape"] == 0.25 and record["joints"] == path.tolist()
    assert "joints" not in candidate_record(GraspCandidate(np.eye(4), 1.0))  # the hand's own path: none given


def test_a_planner_paired_with_a_hand_it_cannot_plan_for_is_told_before_the_trials(capsys):
    """antipodal x inspire_right ran to planner_error trials without a word before them."""
    from manigrasp.bench.config import parse_config
    from manigrasp.bench.runner import validate

    validate(parse_config({"objects": ["mug"], "hands": ["parallel_jaw", "inspire_right"],
                           "planners": ["antipodal", "power"]}))
    err = capsys.readouterr().err
    assert "planner 'antipodal' plans for parallel hands only: its trials with inspire_right (dexterous)" in err
    assert "'power'" not in err and "parallel_jaw (" not in err
