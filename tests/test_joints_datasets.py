"""Per-grasp joints through the results store and grasp files: a dexterous trial's joints are stored, replayed,
labelled into the native format and read back by the `file` planner with the same statuses."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import trimesh
from joint_planners import own_path

from manigrasp import hands
from manigrasp.bench.config import parse_config
from manigrasp.bench.label import label
from manigrasp.bench.replay import replay_trial, stored_trials
from manigrasp.bench.runner import run_benchmark
from manigrasp.bench.store import ResultsStore, joints_from_text, joints_text
from manigrasp.graspsets import GraspFileError, GraspSet, native, placement_defect, read

HAND = "fourier_right"


def _statuses(run_dir: Path) -> dict[int, str]:
    with ResultsStore(run_dir / "results.sqlite") as store:
        return {int(r["grasp_index"]): str(r["status"]) for r in store.rows()}


@pytest.fixture(scope="module")
def labelled(tmp_path_factory) -> tuple:
    folder = tmp_path_factory.mktemp("joints")
    mesh = folder / "can.stl"
    trimesh.creation.cylinder(0.033, 0.12, sections=48).export(mesh)
    config = {"objects": [{"mesh": str(mesh), "name": "can", "mass": 0.35}], "hands": [HAND],
              "planners": ["joint_planners:SideGrasps"], "grasps_per_object": 2, "protocol": "lift"}
    run_dir = folder / "run"
    summary = label(parse_config(config), run_dir, progress=False)
    return config, run_dir, summary


@pytest.mark.slow
def test_a_dexterous_run_stores_labels_and_replays_its_joints(labelled, tmp_path):
    config, run_dir, summary = labelled
    statuses = _statuses(run_dir)
    assert statuses == {0: "success", 1: "no_contact"}  # on its own path; the same closing on air
    with ResultsStore(run_dir / "results.sqlite") as store:
        rows = sorted(store.rows(), key=lambda r: int(r["grasp_index"]))
    expected = own_path(hands.load(HAND))
    for row in rows:  # stored exactly (JSON text of the float64 values)
        np.testing.assert_array_equal(joints_from_text(str(row["grasp_joints"])), expected)
    # Replay re-executes the stored joints: the same status for each trial.
    for trial_id in stored_trials(run_dir):
        replay = replay_trial(run_dir, trial_id)
        assert replay.same_status, (trial_id, replay.stored.status, replay.replayed.detail)
    # label wrote the native file with the joints, and said why there is no ACRONYM file.
    (item,) = summary.exported
    assert [Path(f).suffix for f in item.files] == [".json"] and "parallel-jaw grasps only" in item.note
    grasps = read(item.files[0])
    np.testing.assert_array_equal(grasps.joints, np.stack([expected, expected]))
    # The file planner passes them through: the same statuses trial for trial.
    again = dict(config, planners=[{"name": "file", "params": {"path": str(item.files[0])}}])
    run_benchmark(parse_config(again), tmp_path / "again", progress=False)
    assert _statuses(tmp_path / "again") == statuses


def test_joints_text_round_trips_exactly_and_none_is_empty():
    joints = np.array([[0.1, 1 / 3, -2.5e-7], [np.pi, 0.0, 1e300]])
    np.testing.assert_array_equal(joints_from_text(joints_text(joints)), joints)
    assert joints_text(None) == "" and joints_from_text("") is None


def _set(joints: np.ndarray | None, hand_kind: str = "dexterous") -> GraspSet:
    n = 2
    return GraspSet(np.tile(np.eye(4), (n, 1, 1)), np.full(n, np.nan), np.zeros(n), np.array([1.0, 0.5]),
                    hand=HAND, hand_kind=hand_kind, joints=joints)


@pytest.mark.parametrize("suffix", [".json", ".npz"])
def test_native_files_round_trip_joints_and_a_grasp_without_them(tmp_path, suffix):
    joints = np.stack([np.arange(12.0).reshape(2, 6) / 10, np.full((2, 6), np.nan)])  # grasp 1: the hand's own
    back = native.read(native.write(_set(joints), tmp_path / f"g{suffix}"))
    np.testing.assert_array_equal(back.grasp_joints(0), joints[0])
    assert back.grasp_joints(1) is None
    assert native.read(native.write(_set(None), tmp_path / f"none{suffix}")).joints is None


def test_native_json_joints_of_different_shapes_or_rows_are_refused(tmp_path):
    path = tmp_path / "bad.json"
    pose = np.eye(4).tolist()
    path.write_text(json.dumps({"grasps": [{"pose": pose, "joints": [[0, 1], [1, 2]]},
                                           {"pose": pose, "joints": [[0, 1, 2], [1, 2, 3]]}]}))
    with pytest.raises(GraspFileError, match=r"grasp 1: joints have shape \(2, 3\)"):
        native.read(path)
    path.write_text(json.dumps({"grasps": [{"pose": pose, "joints": [[0, 1, 2]]}]}))
    with pytest.raises(GraspFileError, match="grasp 0: joints must be"):
        native.read(path)


def test_a_non_unit_quaternion_is_a_file_error_naming_the_grasp(tmp_path):
    """(2, 0, 0, 0) gave the identity (the formula cannot see a scaled w): it is refused, not executed."""
    path = tmp_path / "q.json"
    good = {"position": [0, 0, 0], "quaternion": [1, 0, 0, 0]}
    path.write_text(json.dumps({"grasps": [good, {"position": [0, 0, 0], "quaternion": [2, 0, 0, 0]}]}))
    with pytest.raises(GraspFileError, match=r"grasp 1: quaternion \[2\.0, 0\.0, 0\.0, 0\.0\] is not a unit quat"):
        native.read(path)
    npz = tmp_path / "q.npz"
    np.savez(npz, positions=np.zeros((3, 3)), quaternions=np.array([[1, 0, 0, 0], [1, 0, 0, 0], [0, 0.5, 0, 0]]))
    with pytest.raises(GraspFileError, match="grasp 2: quaternion"):
        native.read(npz)
    np.savez(npz, positions=np.zeros((1, 3)), quaternions=np.array([[np.nan, 0, 0, 0]]))
    assert np.isnan(native.read(npz).poses).any()  # a NaN quaternion stays: that grasp is invalid_grasp


def test_joints_of_a_set_on_a_parallel_hand_are_invalid_grasp():
    grasps = _set(np.zeros((2, 2, 6)), hand_kind=None)
    # A set naming its dexterous hand is that hand's kind: refused on a parallel hand by kind.
    assert "is a dexterous grasp" in placement_defect(grasps, 0, "parallel_jaw", "parallel", 0.1, transfer=True)
    anyone = replace(grasps, hand=None)  # a set naming no hand nor kind: its joints make it invalid there
    assert "parallel hand" in placement_defect(anyone, 0, "parallel_jaw", "parallel", 0.1, transfer=True)
    assert placement_defect(grasps, 0, HAND, "dexterous", 0.1, n_actuators=6) is None
    assert "needs (2, 16)" in placement_defect(grasps, 0, "allegro_right", "dexterous", 0.1, True, 16)


def test_a_file_grasp_whose_joints_do_not_fit_the_hand_is_an_invalid_candidate_not_a_planner_error(tmp_path):
    from manigrasp import planners
    from manigrasp.planners.file import FilePlanner

    joints = np.stack([np.zeros((2, 6)), np.zeros((2, 6))])
    joints[1, 1] = 0.5  # grasp 1: a path the hand can take (rows differ)
    grasps = GraspSet(np.tile(np.eye(4), (2, 1, 1)), np.full(2, np.nan), np.zeros(2), np.array([1.0, 0.5]),
                      hand_kind="dexterous", joints=joints)
    path = native.write(grasps, tmp_path / "six.json")
    observation = planners.Observation(object_pose=np.eye(4), mesh=trimesh.creation.box((0.05,) * 3))
    allegro = hands.load("allegro_right")  # 16 actuators: neither grasp fits
    result = planners.plan(FilePlanner(str(path)), observation, allegro, 2, np.random.default_rng(0))
    assert all("needs (2, 16)" in c.invalid for c in result.candidates)
    fourier = hands.load(HAND)
    result = planners.plan(FilePlanner(str(path)), observation, fourier, 2, np.random.default_rng(0))
    assert [c.invalid for c in result.candidates] == ["", ""]
    np.testing.assert_array_equal(result.candidates[1].joints, joints[1])
