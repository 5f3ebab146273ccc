"""`label`'s exporter on stored trials (no simulation): which trials become grasps, the summary, the object's
name under resting poses, and the files `evaluate` reads back (the object check, the object of an .h5)."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import h5py
import numpy as np
import pytest

from manigrasp.bench.config import parse_config
from manigrasp.bench.label import export_dataset
from manigrasp.bench.store import ResultsStore, TrialKey
from manigrasp.cli import main
from manigrasp.errors import ConfigError
from manigrasp.graspsets import GraspSet, ObjectRef, acronym, native, read, write
from manigrasp.protocol.result import PoseRecord, Status, TrialResult

CAN = "005_tomato_soup_can"
CONFIG = {"objects": [CAN], "planners": ["random"], "grasps_per_object": 4, "protocol": "lift"}


def _top_down(height: float) -> np.ndarray:
    pose = np.eye(4)
    pose[:3, :3] = np.diag([-1.0, 1.0, -1.0])
    pose[:3, 3] = [0.0, 0.0, height]
    return pose


def _store(run_dir: Path, statuses: list[Status], label: str = CAN, rest_index: int = -1,
           planned: frozenset = frozenset({Status.SUCCESS, Status.SLIPPED_LIFT, Status.NO_CONTACT})) -> list[str]:
    """A results store of one group of `label`: a trial per status, those in `planned` with a grasp; its ids."""
    obj = np.eye(4)
    obj[:3, 3] = [0.1, 0.0, 0.05]
    ids = []
    with ResultsStore(run_dir / "results.sqlite") as store:
        for i, status in enumerate(statuses):
            key = TrialKey(label, "parallel_jaw", "random", "ground_truth", "lift", i)
            grasp = PoseRecord.of(obj @ _top_down(0.02 + 0.01 * i)) if status in planned else PoseRecord()
            store.add(key, TrialResult(status=status, grasp=grasp, object_pose=PoseRecord.of(obj), seed=i,
                                       rest_index=rest_index, rest_probability=0.5 if rest_index >= 0 else math.nan))
            ids.append(key.trial_id)
    return ids


def test_trials_without_a_grasp_are_left_out_and_counted_by_status(tmp_path):
    """A planning timeout or a harness fault before the grasp was written as an all-NaN grasp labelled
    `timeout` (only planner_error and no_grasp were left out)."""
    statuses = [Status.SUCCESS, Status.TIMEOUT, Status.NO_GRASP, Status.HARNESS_FAULT, Status.SLIPPED_LIFT,
                Status.PLANNER_ERROR, Status.TIMEOUT]
    ids = _store(tmp_path, statuses)
    (item,), without = export_dataset(tmp_path, parse_config(CONFIG))
    assert without == {"timeout": 2, "no_grasp": 1, "harness_fault": 1, "planner_error": 1}
    assert item.grasps == 2 and item.trial_ids == (ids[0], ids[4])


def test_a_harness_fault_after_the_grasp_has_no_label_and_is_not_written(tmp_path):
    """A bug of manigrasp that stopped a trial after its grasp was written as a failed grasp (success false): a
    label physics never gave, and the summary's share counted it where every report leaves it out."""
    ids = _store(tmp_path, [Status.SUCCESS, Status.HARNESS_FAULT, Status.SLIPPED_LIFT],
                 planned=frozenset({Status.SUCCESS, Status.HARNESS_FAULT, Status.SLIPPED_LIFT}))
    (item,), without = export_dataset(tmp_path, parse_config(CONFIG))
    assert without == {"harness_fault": 1}
    assert (item.grasps, item.successes, item.trial_ids) == (2, 1, (ids[0], ids[2]))
    for path in item.files:
        grasps = read(path)
        assert len(grasps) == 2 and np.all(np.isfinite(grasps.poses))
    assert list(read(item.files[0]).labels["status"]) == ["success", "slipped_lift"]


def test_a_group_without_any_grasp_writes_no_file_and_removes_an_earlier_one(tmp_path):
    _store(tmp_path, [Status.TIMEOUT, Status.TIMEOUT])
    stale = tmp_path / "grasps" / f"{CAN}__parallel_jaw__random.json"
    stale.parent.mkdir()
    stale.write_text("{}")  # what an earlier export wrote of these trials (NaN grasps)
    assert export_dataset(tmp_path, parse_config(CONFIG)) == ([], {"timeout": 2})
    assert not stale.exists()


def test_the_cli_summary_counts_grasps_written_and_trials_without_one_by_status(tmp_path, capsys, monkeypatch):
    """It printed "4 grasps labelled now ... 2 trials without a grasp (planner errors)" for 2 grasps written and
    2 trials that were no_grasp and timeout; its rate counted the trials without a grasp too."""
    import manigrasp.bench.runner

    def run_benchmark(config, run_dir, on_result=None, **_):
        ids = _store(Path(run_dir), [Status.SUCCESS, Status.NO_GRASP, Status.NO_CONTACT, Status.TIMEOUT])
        for trial in ids:
            on_result(SimpleNamespace(trial_id=trial), None)
        return SimpleNamespace(ran=4, already_done=0)

    monkeypatch.setattr(manigrasp.bench.runner, "run_benchmark", run_benchmark)
    config = tmp_path / "c.yaml"
    config.write_text(json.dumps(CONFIG))
    assert main(["label", str(config), "--out", str(tmp_path / "run"), "--quiet", "--jobs", "1"]) == 0
    err = capsys.readouterr().err
    assert "2 grasps written, 2 of them labelled now (4 trials run, 0 already stored)" in err, err
    assert "2 trials not written, without a grasp or a label (no_grasp 1, timeout 1)" in err
    assert "planner errors" not in err


def test_label_summary_rate_counts_grasps_labelled_now():
    from manigrasp.bench.label import Exported, LabelSummary

    item = Exported("g", CAN, "parallel_jaw", 6, 2, (), trial_ids=tuple(f"t{i}" for i in range(6)))
    summary = LabelSummary(Path("run"), 12, 0, 2.0, (item,), {"no_grasp": 6}, labelled_now=6)
    assert summary.written == 6 and summary.skipped == 6 and summary.labelled_per_second == 3.0


def test_a_resting_pose_group_names_its_object_plainly_and_records_the_pose(tmp_path, capsys, monkeypatch):
    """Under rest: stable_k the object's source was looked up by its label (no ACRONYM file: 'mesh not found'),
    and the native file named the object '...@rest0', which evaluate could not resolve."""
    import manigrasp.bench.runner
    import manigrasp.cli.report

    config = parse_config(dict(CONFIG, scene={"rest": "stable_k", "rest_k": 1}))
    _store(tmp_path, [Status.SUCCESS, Status.NO_CONTACT], label=f"{CAN}@rest0", rest_index=0)
    (item,), _ = export_dataset(tmp_path, config)
    assert item.note == "" and [Path(f).suffix for f in item.files] == [".json", ".h5"]
    assert item.object == f"{CAN}@rest0"  # the summary's table still tells the poses apart
    for path in item.files:
        grasps = read(path)
        assert grasps.object.name == CAN
        rest = grasps.labels["rest_index"]
        assert list(rest) == [0, 0]
    configs = []
    monkeypatch.setattr(manigrasp.bench.runner, "run_benchmark",
                        lambda config, *_, **__: configs.append(config) or SimpleNamespace(ran=0, already_done=0,
                                                                                           seconds=0.0))
    monkeypatch.setattr(manigrasp.cli.report, "print_report", lambda *_, **__: 0)
    for path in item.files:
        assert main(["evaluate", str(path), "--out", str(tmp_path / f"ev{path.suffix}"), "--quiet"]) == 0
        assert configs[-1].objects[0].name == CAN, capsys.readouterr().err


@pytest.fixture
def captured(monkeypatch) -> list:
    """Stand-ins for the run and the report: `evaluate`'s config is captured, no trial is simulated."""
    import manigrasp.bench.runner
    import manigrasp.cli.report

    configs: list = []
    monkeypatch.setattr(manigrasp.bench.runner, "run_benchmark",
                        lambda config, *_, **__: configs.append(config) or SimpleNamespace(ran=0, already_done=0,
                                                                                           seconds=0.0))
    monkeypatch.setattr(manigrasp.cli.report, "print_report", lambda *_, **__: 0)
    return configs


def _label_h5(tmp_path: Path) -> Path:
    _store(tmp_path, [Status.SUCCESS, Status.NO_CONTACT])
    (item,), _ = export_dataset(tmp_path, parse_config(CONFIG))
    return Path(item.files[1])


def test_a_label_h5_names_its_object_and_evaluate_builds_that_object(tmp_path, captured):
    """evaluate of a label-written .h5 built a new object named "visual" from the cached visual mesh."""
    path = _label_h5(tmp_path)
    with h5py.File(path) as handle:
        assert handle[acronym.NAME_KEY][()].decode() == CAN and "object/file" in handle
    grasps = read(path)
    assert grasps.object.name == CAN and grasps.object.built
    assert main(["evaluate", str(path), "--out", str(tmp_path / "ev"), "--quiet"]) == 0
    (config,) = captured
    assert config.objects[0].name == CAN and config.objects[0].mesh is None  # the shipped object, by its name


def test_an_h5_of_another_object_is_refused_unless_any_object(tmp_path, captured, capsys):
    """An .h5 of one object ran silently on --object OTHER, its grasps shifted by OTHER's centre of mass."""
    path = _label_h5(tmp_path)
    capsys.readouterr()
    assert main(["evaluate", str(path), "--object", "025_mug", "--out", str(tmp_path / "ev"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert f"holds grasps of object {CAN!r}, not '025_mug'" in err and "--any-object" in err and not captured
    assert main(["evaluate", str(path), "--object", "025_mug", "--any-object", "--out", str(tmp_path / "ev"),
                 "--quiet"]) == 0
    assert captured[0].objects[0].name == "025_mug"


def test_the_file_planner_refuses_a_mesh_frame_set_of_another_object(tmp_path):
    from manigrasp import hands
    from manigrasp.errors import PlannerError
    from manigrasp.objects import catalog
    from manigrasp.planners import Observation
    from manigrasp.planners.file import FilePlanner

    path = _label_h5(tmp_path)
    hand = hands.load("parallel_jaw")
    mug = Observation.from_asset(catalog.build(catalog.shipped("025_mug")).asset, np.eye(4))
    with pytest.raises(PlannerError, match=f"holds grasps of object {CAN!r}, not '025_mug'"):
        FilePlanner(str(path)).plan(mug, hand, 1, np.random.default_rng(0))
    assert len(FilePlanner(str(path), check_object=False).plan(mug, hand, 1, np.random.default_rng(0))) == 1
    can = Observation.from_asset(catalog.build(catalog.shipped(CAN)).asset, np.eye(4))
    (candidate,) = FilePlanner(str(path)).plan(can, hand, 1, np.random.default_rng(0))
    np.testing.assert_allclose(candidate.pose, read(path).poses[0], atol=1e-12)  # label's frame is the object's


def test_an_acronym_file_of_a_mesh_object_is_that_object_whatever_its_name(tmp_path, captured):
    """A real ACRONYM file names its object by its mesh's stem: --object that mesh --name other still runs."""
    import trimesh

    mesh = tmp_path / "abc123.obj"
    trimesh.creation.box(extents=(0.04, 0.05, 0.06)).export(mesh)
    path = tmp_path / "abc.h5"
    with h5py.File(path, "w") as f:
        f["grasps/transforms"] = np.eye(4)[None]
        f["object/file"] = mesh.name
        f["object/scale"] = 1.0
    grasps = read(path)
    assert grasps.object.name == "abc123" and not grasps.object.built  # no manigrasp key: as before
    assert main(["evaluate", str(path), "--object", str(mesh), "--name", "box_b", "--out", str(tmp_path / "ev"),
                 "--quiet"]) == 0
    assert captured[0].objects[0].name == "box_b"


def test_native_json_writes_nan_as_null_and_reads_it_back(tmp_path):
    """label's .json held bare NaN tokens (not JSON: JavaScript's JSON.parse refuses them)."""
    pose = _top_down(0.02)
    nan_pose = np.full((4, 4), np.nan)
    grasps = GraspSet(np.stack([pose, nan_pose]), np.array([0.03, np.nan]), np.zeros(2), np.array([1.0, 0.0]),
                      object=ObjectRef(name=CAN), labels={"status": np.array(["success", "timeout"]),
                                                         "grip_force_n": np.array([12.5, np.nan]),
                                                         "fingers_in_contact": np.array([2, 0])})
    path = native.write(grasps, tmp_path / "g.json")

    def refuse(token: str) -> None:
        raise ValueError(f"non-standard JSON token {token}")

    json.loads(path.read_text(), parse_constant=refuse)  # strict JSON
    back = read(path)
    np.testing.assert_array_equal(back.poses, grasps.poses)
    np.testing.assert_array_equal(back.labels["grip_force_n"], [12.5, np.nan])
    assert list(back.labels["status"]) == ["success", "timeout"] and back.labels["grip_force_n"].dtype == float
    # A file written before, with bare NaN tokens, reads the same.
    old = tmp_path / "old.json"
    old.write_text(path.read_text().replace("null", "NaN"))
    np.testing.assert_array_equal(read(old).labels["grip_force_n"], [12.5, np.nan])
    np.testing.assert_array_equal(read(old).poses, grasps.poses)


def test_the_acronym_docstring_names_only_keys_label_writes():
    """It said label-written files store success as ``object_in_gripper`` (ACRONYM's FleX key); they do not."""
    label_part = acronym.__doc__.split("Files written by")[1]
    assert "object_in_gripper" not in label_part


def test_the_file_planner_knows_a_mesh_frame_set_of_the_objects_own_mesh_by_its_file(tmp_path):
    """An ACRONYM file names its object by its mesh's stem; an object built from that very mesh file under another
    name is its object (the planner's check by name would refuse it)."""
    from manigrasp.planners.file import same_mesh

    mesh = tmp_path / "meshes" / "abc123.obj"
    mesh.parent.mkdir()
    mesh.write_text("")
    grasps = GraspSet(np.eye(4)[None], np.full(1, np.nan), np.zeros(1), np.zeros(1), frame="mesh",
                      object=ObjectRef(name="abc123", mesh="meshes/abc123.obj"), source=str(tmp_path / "g.h5"))
    built = SimpleNamespace(visual_path=tmp_path / "cache" / "visual.obj", metadata={"source": str(mesh)})
    other = SimpleNamespace(visual_path=tmp_path / "cache" / "visual.obj", metadata={"source": "recipe (ycb)"})
    assert same_mesh(grasps, built) and not same_mesh(grasps, other)
    assert not same_mesh(replace(grasps, frame="object"), built)  # an object-frame set names its object by name


def test_each_set_of_an_object_with_a_dot_in_its_name_gets_its_own_file(tmp_path):
    """`Path.with_suffix` took ``.v2__parallel_jaw__random`` of ``box.v2`` for a suffix: every set of the object
    went to ``box.json`` over the one before, and an empty group's clean-up deleted another set's file."""
    import trimesh

    mesh = tmp_path / "box.stl"
    trimesh.creation.box((0.05, 0.06, 0.08)).export(mesh)
    config = parse_config({"objects": [{"mesh": str(mesh), "name": "box.v2"}], "planners": ["random", "antipodal"],
                           "grasps_per_object": 2, "protocol": "lift"})
    run = tmp_path / "run"
    run.mkdir()
    with ResultsStore(run / "results.sqlite") as store:
        for planner, status in (("random", Status.SUCCESS), ("antipodal", Status.SLIPPED_LIFT)):
            for i in range(2):
                key = TrialKey("box.v2", "parallel_jaw", planner, "ground_truth", "lift", i)
                store.add(key, TrialResult(status=status, grasp=PoseRecord.of(_top_down(0.02 + 0.01 * i)),
                                           object_pose=PoseRecord.of(np.eye(4)), seed=i))
    items, _ = export_dataset(run, config)
    files = {f.name for item in items for f in item.files if f.suffix == ".json"}
    assert files == {"box.v2__parallel_jaw__random.json", "box.v2__parallel_jaw__antipodal.json"}
    for item in items:
        labels = read(next(f for f in item.files if f.suffix == ".json")).labels["status"]
        assert set(labels) == {"success" if "random" in item.files[0].name else "slipped_lift"}


def test_a_directory_of_a_resting_pose_dataset_gives_each_pose_its_file(tmp_path):
    """Under rest: stable_k label names its files '<object>_rest<i>__...'; the file planner looked only for
    '<object>__<hand>*' and '<object>__*', so one config with the same scene could not evaluate the directory."""
    from manigrasp import hands
    from manigrasp.objects import catalog
    from manigrasp.planners import Observation, plan
    from manigrasp.planners.context import PlanContext
    from manigrasp.planners.file import FilePlanner, grasp_file_for
    from manigrasp.sim.config import SceneConfig

    config = parse_config(dict(CONFIG, scene={"rest": "stable_k", "rest_k": 2}))
    _store(tmp_path, [Status.SUCCESS, Status.NO_CONTACT], label=f"{CAN}@rest0", rest_index=0)
    _store(tmp_path, [Status.SUCCESS], label=f"{CAN}@rest1", rest_index=1)
    exported, _ = export_dataset(tmp_path, config)
    files = {item.object: Path(item.files[0]) for item in exported}
    folder = tmp_path / "grasps"
    for rest in (0, 1):
        assert grasp_file_for(folder, CAN, "parallel_jaw", rest) == files[f"{CAN}@rest{rest}"]
    context = PlanContext(0.1, None, 0.5, 0.0, scene=SceneConfig(rest="stable_k", rest_k=2, rest_index=1))
    assert context.rest_index == 1 and context.scene.rest == "file"
    observation = Observation.from_asset(catalog.build(catalog.shipped(CAN)).asset, np.eye(4))
    result = plan(FilePlanner(str(folder)), observation, hands.load("parallel_jaw"), 2, np.random.default_rng(0),
                  context=context)
    assert len(result.candidates) == 1  # rest1's one grasp, not rest0's two


def _assert_same_set(a: GraspSet, b: GraspSet) -> None:
    # Poses pass through ACRONYM's gripper frame (a product with ACRONYM_TO_TCP and back): equal to rounding.
    np.testing.assert_allclose(b.poses, a.poses, rtol=0, atol=1e-15)
    for name in ("widths", "preshapes", "scores"):
        np.testing.assert_array_equal(getattr(b, name), getattr(a, name))
    assert (b.frame, b.hand, b.hand_kind, b.object) == (a.frame, a.hand, a.hand_kind, a.object)
    assert sorted(b.labels) == sorted(a.labels)
    for key, value in a.labels.items():
        assert b.labels[key].dtype.kind == value.dtype.kind, key
        np.testing.assert_array_equal(b.labels[key], value, err_msg=key)


def test_a_label_h5_reads_writes_and_reads_back_the_same_set_in_either_format(tmp_path, captured):
    """write(read(x.h5)) raised OSError (read put manigrasp/planner_score among the labels, write wrote it again);
    labels came back as 'manigrasp/status'; a .json converted from a label .h5 lost `built`, so evaluate refused it."""
    first = read(_label_h5(tmp_path))
    assert "status" in first.labels and not any(k.startswith("manigrasp/") for k in first.labels)
    for suffix in (".h5", ".json", ".npz"):
        again = read(write(first, tmp_path / f"conv{suffix}"))
        _assert_same_set(first, again)
        _assert_same_set(again, read(write(again, tmp_path / f"twice{suffix}")))
    assert main(["evaluate", str(tmp_path / "conv.json"), "--out", str(tmp_path / "ev"), "--quiet"]) == 0
    assert captured[0].objects[0].name == CAN and captured[0].objects[0].mesh is None


def test_the_native_file_names_the_object_its_labels_were_measured_on(tmp_path):
    """The native file named its object by name alone: a config's mass (a 3 kg sugar box) was lost, so
    `evaluate FILE.json` re-ran its drops as successes at the shipped mass, and a mesh object's file was refused
    (an unknown object) where the .h5 beside it ran."""
    import trimesh

    _store(tmp_path, [Status.SUCCESS, Status.SLIPPED_LIFT])
    (item,), _ = export_dataset(tmp_path, parse_config(dict(CONFIG, objects=[{"name": CAN, "mass": 0.9}])))
    ref = read(next(f for f in item.files if f.suffix == ".json")).object
    assert (ref.name, ref.mass, ref.mesh) == (CAN, 0.9, None)
    (item,), _ = export_dataset(tmp_path, parse_config(CONFIG))  # the shipped mass: none written, as before
    assert read(next(f for f in item.files if f.suffix == ".json")).object == ObjectRef(name=CAN)
    mesh = tmp_path / "part.stl"
    trimesh.creation.box((50.0, 60.0, 80.0)).export(mesh)  # in millimetres
    run = tmp_path / "mesh_run"
    _store(run, [Status.SUCCESS], label="part")
    config = parse_config(dict(CONFIG, objects=[{"mesh": str(mesh), "name": "part", "scale": 0.001,
                                                  "density": 800.0}]))
    (item,), _ = export_dataset(run, config)
    ref = read(next(f for f in item.files if f.suffix == ".json")).object
    assert (ref.name, ref.mesh, ref.scale) == ("part", str(mesh.resolve()), 0.001)
    assert ref.mass == pytest.approx(800.0 * 0.05 * 0.06 * 0.08)  # evaluate has no density: the mass it gave


def test_a_dataset_records_what_it_was_labelled_under_and_evaluate_runs_under_it(tmp_path, captured, capsys):
    """A set labelled under `lift` with rigid pads re-ran under `standard` with compliant pads by default: its
    labels (drops of a protocol it never ran) no longer described the run. The files now record the protocol
    with its parameters and every scene parameter (a default changed since does not change the re-run; rest:
    most_stable too, one pose; not stable_k's settings), in JSON, NPZ and ACRONYM files alike, and evaluate uses
    them; a record of the non-default parameters only (files of before 5 Dec 2026) still runs."""
    from manigrasp.config import to_mapping

    _store(tmp_path, [Status.SUCCESS, Status.SLIPPED_LIFT])
    config = parse_config(dict(CONFIG, protocol={"name": "lift", "params": {"hold_s": 1.0}},
                               scene={"pads": "rigid", "rest": "most_stable"}))
    (item,), _ = export_dataset(tmp_path, config)
    scene = json.loads(json.dumps(to_mapping(config.scene), default=str))
    expected = {"protocol": {"name": "lift", "params": {"hold_s": 1.0}}, "scene": scene}
    assert scene["pads"] == "rigid" and scene["rest"] == "most_stable" and scene["pad_pitch"] == 0.015
    for path in item.files:
        assert read(path).labelled_under == expected, path.suffix
    native_file = next(f for f in item.files if f.suffix == ".json")
    assert read(write(read(native_file), tmp_path / "copy.npz")).labelled_under == expected  # NPZ keeps it too
    assert main(["evaluate", str(native_file), "--out", str(tmp_path / "ev"), "--quiet"]) == 0
    assert "protocol lift(hold_s=1.0), as the file was labelled; scene pads=rigid, rest=most_stable" in \
        capsys.readouterr().err
    assert main(["evaluate", str(native_file), "--out", str(tmp_path / "ev2"), "--quiet", "--protocol",
                 "standard"]) == 0
    first, second = captured
    assert (first.protocol.name, dict(first.protocol.params), first.scene.pads, first.scene.rest) == \
        ("lift", {"hold_s": 1.0}, "rigid", "most_stable")
    assert (second.protocol.name, second.scene.pads) == ("standard", "rigid")  # --protocol wins; the scene stays
    # A default changed after labelling (the pads' grid, say) does not change the re-run: the file's value runs.
    # An older file's record of the non-default parameters only runs under today's defaults for the rest.
    for name, recorded in (("older_default.json", {**scene, "pad_pitch": 0.01}),
                           ("diff_only.json", {"pads": "rigid", "rest": "most_stable"})):
        write(replace(read(native_file), labelled_under={**expected, "scene": recorded}), tmp_path / name)
        assert main(["evaluate", str(tmp_path / name), "--out", str(tmp_path / f"ev_{name}"), "--quiet"]) == 0
        assert (captured[-1].scene.pads, captured[-1].scene.rest) == ("rigid", "most_stable")
        assert captured[-1].scene.pad_pitch == recorded.get("pad_pitch", 0.015)
    # A file without the record runs as before (standard, default scene); a malformed record is a file error.
    plain = tmp_path / "plain.json"
    write(replace(read(native_file), labelled_under=None), plain)
    assert main(["evaluate", str(plain), "--out", str(tmp_path / "ev3"), "--quiet"]) == 0
    assert captured[-1].protocol.name == "standard" and captured[-1].scene.pads == "compliant"
    data = json.loads(native_file.read_text())
    data["labelled_under"] = {"protocol": "lift", "sceen": {}}
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(data))
    assert main(["evaluate", str(bad), "--out", str(tmp_path / "ev4"), "--quiet"]) == 2
    assert "labelled_under: unknown key 'sceen'" in capsys.readouterr().err
    other = tmp_path / "other"  # a store of its own: these exports write over the files above
    _store(other, [Status.SUCCESS])
    (item,), _ = export_dataset(other, parse_config(dict(CONFIG, scene={"rest": "stable_k", "rest_k": 2})))
    recorded = read(item.files[0]).labelled_under["scene"]  # stable_k: each group is one pose (rest_index)
    assert recorded["pads"] == "compliant" and not any(k.startswith("rest") for k in recorded)
    with pytest.raises(ConfigError, match="protocol 'lift', which the config does not list"):
        export_dataset(other, parse_config(dict(CONFIG, protocol="standard")))
