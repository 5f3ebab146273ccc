"""Grasp files in: the native format and ACRONYM's layout, placing grasps on the object, bad files."""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np
import pytest
import trimesh

from manigrasp import hands
from manigrasp.graspsets import GraspFileError, acronym, native, read
from manigrasp.objects import catalog
from manigrasp.planners import Observation, plan
from manigrasp.planners.file import FilePlanner
from manigrasp.protocol.result import Status

# A top-down grasp of a (4, 4) TCP in the object frame: z (approach) = -z, y (closing) = +y, x = y cross z = -x.
TOP_DOWN = np.array([[-1.0, 0, 0, 0], [0, 1, 0, 0], [0, 0, -1, 0], [0, 0, 0, 1]])


def _rot_z(deg: float) -> np.ndarray:
    out = np.eye(4)
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    out[:2, :2] = [[c, -s], [s, c]]
    return out


def _write_json(path: Path, data: dict) -> Path:
    path.write_text(json.dumps(data))
    return path


@pytest.fixture(scope="module")
def shifted_box(tmp_path_factory) -> tuple:
    """A 4 x 6 x 8 cm box whose mesh file puts its centre (= centre of mass) at COM, not at the origin."""
    folder = tmp_path_factory.mktemp("box")
    com = np.array([0.01, -0.02, 0.05])
    mesh = trimesh.creation.box(extents=(0.04, 0.06, 0.08))
    mesh.apply_translation(com)
    path = folder / "shifted_box.obj"
    mesh.export(path)
    asset = catalog.build(catalog.ObjectSource(name="shifted_box", mesh=str(path), mass=0.2)).asset
    return asset, path, com


def test_acronym_gripper_frame_maps_onto_the_tcp_and_back():
    # ACRONYM's fingers close along its x and its pads' centre lies 0.1034 m along z: TCP y = gripper x, same z.
    gripper = _rot_z(30.0)
    gripper[:3, 3] = [0.1, 0.2, 0.3]
    tcp = acronym.tcp_from_acronym(gripper)
    np.testing.assert_allclose(tcp[:3, 1], gripper[:3, 0], atol=1e-12)
    np.testing.assert_allclose(tcp[:3, 2], gripper[:3, 2], atol=1e-12)
    np.testing.assert_allclose(tcp[:3, 3], gripper[:3, 3] + 0.1034 * gripper[:3, 2], atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(tcp[:3, :3]), 1.0)
    np.testing.assert_allclose(acronym.acronym_from_tcp(tcp), gripper, atol=1e-12)


def test_acronym_file_lands_on_the_expected_world_poses(tmp_path, shifted_box):
    asset, mesh_path, com = shifted_box
    down = np.eye(4)  # gripper 2 cm + 0.1034 m above the box centre, pointing down (180 degrees about x)
    down[:3, :3] = np.diag([1.0, -1.0, -1.0])
    down[:3, 3] = com + [0, 0, 0.1034 + 0.02]
    side = np.eye(4)  # approaching along +x, fingers (x) along +y, reaching the box centre
    side[:3, :3] = np.column_stack([[0, 1, 0], [0, 0, 1], [1, 0, 0]])
    side[:3, 3] = com - [0.1034, 0, 0]
    broken = np.full((4, 4), np.nan)
    path = tmp_path / "box.h5"
    with h5py.File(path, "w") as f:
        f["grasps/transforms"] = np.stack([down, side, broken])
        f["grasps/qualities/flex/object_in_gripper"] = np.array([1, 0, 1])
        f["object/file"] = mesh_path.name
        f["object/scale"] = 1.0
        f["object/mass"] = 0.2
    mesh_path_copy = tmp_path / mesh_path.name
    mesh_path_copy.write_bytes(mesh_path.read_bytes())
    grasps = read(path)
    assert grasps.frame == "mesh" and grasps.object.mesh == mesh_path.name and grasps.object.mass == 0.2
    np.testing.assert_array_equal(grasps.labels["flex/object_in_gripper"], [1, 0, 1])

    rest = _rot_z(40.0)
    rest[:3, 3] = [0.3, -0.1, 0.04]
    observation = Observation.from_asset(asset, rest)
    result = plan(FilePlanner(str(path)), observation, hands.load("parallel_jaw"), 3, np.random.default_rng(0))
    first, second, third = result.candidates
    world = rest[:3, :3]
    np.testing.assert_allclose(first.position, rest[:3, 3] + world @ [0, 0, 0.02], atol=1e-9)
    np.testing.assert_allclose(first.approach, world @ [0, 0, -1], atol=1e-9)
    np.testing.assert_allclose(first.closing, world @ [1, 0, 0], atol=1e-9)
    np.testing.assert_allclose(second.position, rest[:3, 3], atol=1e-9)
    np.testing.assert_allclose(second.approach, world @ [1, 0, 0], atol=1e-9)
    np.testing.assert_allclose(second.closing, world @ [0, 1, 0], atol=1e-9)
    assert not first.invalid and not second.invalid and "NaN" in third.invalid
    # ACRONYM grasps are parallel-jaw grasps: every one is invalid on a five-finger hand, none is dropped.
    dexterous = plan(FilePlanner(str(path)), observation, hands.load("inspire_right"), 3, np.random.default_rng(0))
    assert len(dexterous.candidates) == 3 and all("dexterous" in c.invalid for c in dexterous.candidates)


def test_native_json_and_npz_read_the_same_grasps(tmp_path):
    pose = TOP_DOWN.copy()
    pose[:3, 3] = [0, 0, 0.07]
    data = {"hand": "parallel_jaw", "object": {"name": "004_sugar_box"},
            "grasps": [{"pose": pose.tolist(), "width": 0.04, "score": 0.2},
                       {"position": [0, 0, 0.07], "quaternion": [0, 0, 1, 0], "score": 0.9, "preshape": 0.1}]}
    from_json = read(_write_json(tmp_path / "g.json", data))
    np.testing.assert_allclose(from_json.poses[0], pose)
    np.testing.assert_allclose(from_json.poses[1], pose, atol=1e-12)  # (0, 0, 1, 0): 180 degrees about y
    assert np.isnan(from_json.widths[1]) and from_json.widths[0] == 0.04
    assert list(from_json.ranked()) == [1, 0] and from_json.hand == "parallel_jaw"
    from_npz = read(native.write(from_json, tmp_path / "g.npz"))
    for name in ("poses", "widths", "preshapes", "scores"):
        np.testing.assert_array_equal(getattr(from_npz, name), getattr(from_json, name))
    assert from_npz.object.name == "004_sugar_box" and from_npz.hand == "parallel_jaw"


def _h5(path: Path, **datasets) -> Path:
    with h5py.File(path, "w") as f:
        for key, value in datasets.items():
            f[key.replace("__", "/")] = value
    return path


GOOD_POSE = np.eye(4).tolist()


@pytest.mark.parametrize(("name", "content", "message"), [
    ("nograsps.json", {"hand": "parallel_jaw"}, "missing key 'grasps'"),
    ("nopose.json", {"grasps": [{"width": 0.03}]}, "grasp 0: missing key 'pose'"),
    ("shape.json", {"grasps": [{"pose": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]}]}, "grasp 0: pose must be 4x4"),
    ("quat.json", {"grasps": [{"position": [0, 0, 0], "quaternion": [1, 0, 0]}]}, "quaternion 4"),
    ("score.json", {"grasps": [{"pose": GOOD_POSE, "score": float("nan")}]}, "score of grasp 0 is nan"),
    ("scale.json", {"object": {"name": "x", "scale": float("nan")}, "grasps": []}, "object scale"),
    ("typo.json", {"grasps": [{"pose": GOOD_POSE, "widht": 0.03}]}, "unknown key 'widht'"),
])
def test_bad_native_files_give_a_one_line_error_naming_the_problem(tmp_path, name, content, message):
    with pytest.raises(GraspFileError, match=message) as info:
        read(_write_json(tmp_path / name, content))
    assert "\n" not in str(info.value) and name in str(info.value)


def test_bad_npz_and_acronym_files_give_a_one_line_error(tmp_path):
    np.savez(tmp_path / "a.npz", poses=np.zeros((3, 3, 3)))
    np.savez(tmp_path / "b.npz", widths=np.zeros(3))
    np.savez(tmp_path / "c.npz", poses=np.tile(np.eye(4), (2, 1, 1)), scores=np.zeros(3))
    cases = [
        (tmp_path / "a.npz", "'poses' must be \\(n, 4, 4\\)"),
        (tmp_path / "b.npz", "missing key 'poses'"),
        (tmp_path / "c.npz", "scores must have shape \\(2,\\)"),
        (_h5(tmp_path / "a.h5", object__file="m.obj", object__scale=1.0), "missing key 'grasps/transforms'"),
        (_h5(tmp_path / "b.h5", grasps__transforms=np.zeros((2, 3, 4)), object__file="m.obj", object__scale=1.0),
         "must be \\(n, 4, 4\\)"),
        (_h5(tmp_path / "c.h5", grasps__transforms=np.tile(np.eye(4), (2, 1, 1)), object__file="m.obj"),
         "missing key 'object/scale'"),
        (_h5(tmp_path / "d.h5", grasps__transforms=np.tile(np.eye(4), (2, 1, 1)), object__file="m.obj",
             object__scale=np.nan), "'object/scale' is nan"),
        (_h5(tmp_path / "e.h5", grasps__transforms=np.tile(np.eye(4), (2, 1, 1)), object__file="m.obj",
             object__scale=1.0, grasps__qualities__flex__object_in_gripper=np.zeros(3)), "one value per grasp"),
        (tmp_path / "missing.json", "no such grasp file"),
    ]
    for path, message in cases:
        with pytest.raises(GraspFileError, match=message) as info:
            read(path)
        assert "\n" not in str(info.value), path


def _sugar_box_grasps(tmp_path: Path) -> Path:
    """A top-down grasp across the sugar box's 3.8 cm side, 1.5 cm below its top (the box is 17.5 cm tall,
    its frame at its centre); the same grasp 15 cm to the side of the box; a NaN grasp; one for another hand."""
    good = TOP_DOWN.copy()
    good[:3, 3] = [0, 0, 0.0875 - 0.015]
    beside = good.copy()
    beside[0, 3] = 0.15
    nan = good.copy()
    nan[2, 3] = np.nan
    grasps = [{"pose": good.tolist(), "width": 0.038, "score": 4.0}, {"pose": beside.tolist(), "score": 3.0},
              {"pose": nan.tolist(), "score": 2.0}]
    return _write_json(tmp_path / "sugar.json", {"hand": "parallel_jaw", "object": {"name": "004_sugar_box"},
                                                 "grasps": grasps})


@pytest.mark.slow
def test_native_grasps_on_a_box_succeed_or_fail_as_placed(tmp_path):
    from manigrasp.bench.store import ResultsStore
    from manigrasp.cli import main

    path = _sugar_box_grasps(tmp_path)  # the file names its object and hand: `evaluate` needs no more
    assert main(["evaluate", str(path), "--out", str(tmp_path / "run"), "--protocol", "lift", "--quiet"]) == 0
    with ResultsStore(tmp_path / "run" / "results.sqlite") as store:
        results = [r for _, r in sorted(store.results(), key=lambda kr: kr[0].grasp_index)]
    assert [r.status for r in results] == [Status.SUCCESS, Status.NO_CONTACT, Status.INVALID_GRASP]
    assert "NaN" in results[2].detail
    # Placed on the settled pose: the executed TCP is 1.5 cm below the box's top, straight down.
    obj, tcp = results[0].object_pose.matrix(), results[0].grasp.matrix()
    np.testing.assert_allclose(np.linalg.inv(obj) @ tcp, np.asarray(json.loads(path.read_text())["grasps"][0]["pose"]),
                               atol=1e-9)


def test_a_grasp_set_for_another_hand_is_invalid_unless_transferred(tmp_path):
    path = _sugar_box_grasps(tmp_path)
    asset = catalog.build(catalog.shipped("004_sugar_box")).asset
    observation = Observation.from_asset(asset)
    panda = hands.load("panda")
    refused = plan(FilePlanner(str(path)), observation, panda, 3, np.random.default_rng(0)).candidates
    assert len(refused) == 3 and all("made for hand 'parallel_jaw'" in c.invalid for c in refused)
    moved = plan(FilePlanner(str(path), transfer=True), observation, panda, 3, np.random.default_rng(0)).candidates
    assert [bool(c.invalid) for c in moved] == [False, False, True]


def test_acronym_write_then_read_keeps_poses_and_labels(tmp_path):
    from manigrasp.graspsets import GraspSet, ObjectRef

    poses = np.stack([TOP_DOWN, _rot_z(30.0)])
    grasps = GraspSet(poses, np.array([0.03, np.nan]), np.zeros(2), np.array([2.0, 1.0]), frame="mesh",
                      object=ObjectRef(mesh="m.obj", scale=0.5, mass=0.3),
                      labels={"status": np.array(["success", "dropped_perturb: 15° about +x"]),
                              "grip_force_n": np.array([20.0, np.nan])})
    back = read(acronym.write(grasps, tmp_path / "set.h5"))
    np.testing.assert_allclose(back.poses, poses, atol=1e-12)
    np.testing.assert_array_equal(back.widths, grasps.widths)
    np.testing.assert_array_equal(back.scores, grasps.scores)
    assert list(back.labels["status"]) == list(grasps.labels["status"])
    assert back.object == ObjectRef(name="m", mesh="m.obj", scale=0.5, mass=0.3)


def test_a_directory_gives_the_one_file_of_the_object_and_hand(tmp_path):
    from manigrasp.errors import PlannerError
    from manigrasp.planners.file import grasp_file_for

    for name in ("mug__parallel_jaw__antipodal.json", "mug__parallel_jaw__antipodal.h5", "box__panda.npz"):
        (tmp_path / name).write_text("")
    assert grasp_file_for(tmp_path, "mug", "parallel_jaw").name == "mug__parallel_jaw__antipodal.json"
    assert grasp_file_for(tmp_path, "box", "panda").name == "box__panda.npz"
    (tmp_path / "mug__parallel_jaw__random.json").write_text("")
    with pytest.raises(PlannerError, match="2 grasp files .* match 'mug__parallel_jaw'"):
        grasp_file_for(tmp_path, "mug", "parallel_jaw")
    with pytest.raises(PlannerError, match="no grasp file for object 'can'"):
        grasp_file_for(tmp_path, "can", "panda")


def test_acronym_mesh_paths_resolve_from_the_dataset_root(tmp_path):
    from manigrasp.graspsets import mesh_path

    (tmp_path / "meshes" / "Mug").mkdir(parents=True)
    (tmp_path / "meshes" / "Mug" / "m.obj").write_text("")
    (tmp_path / "grasps").mkdir()
    path = _h5(tmp_path / "grasps" / "Mug_m_0.01.h5", grasps__transforms=np.tile(np.eye(4), (1, 1, 1)),
               object__file="meshes/Mug/m.obj", object__scale=0.01)
    assert mesh_path(read(path)) == tmp_path / "meshes" / "Mug" / "m.obj"


@pytest.mark.slow
def test_evaluate_an_acronym_file_end_to_end(tmp_path, shifted_box):
    from manigrasp.bench.store import ResultsStore
    from manigrasp.cli import main

    _, mesh, com = shifted_box
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / mesh.name).write_bytes(mesh.read_bytes())
    down = np.eye(4)  # the gripper above the box pointing down: its pads 2 cm below the top, closing across 4 cm
    down[:3, :3] = np.diag([1.0, -1.0, -1.0])
    down[:3, 3] = com + [0, 0, 0.1034 + 0.02]
    away = down.copy()
    away[0, 3] += 0.2
    (tmp_path / "grasps").mkdir()
    path = _h5(tmp_path / "grasps" / "box.h5", grasps__transforms=np.stack([down, away]),
               object__file=f"meshes/{mesh.name}", object__scale=1.0, object__mass=0.2)
    assert main(["evaluate", str(path), "--out", str(tmp_path / "run"), "--protocol", "lift", "--quiet"]) == 0
    with ResultsStore(tmp_path / "run" / "results.sqlite") as store:
        statuses = [r.status for _, r in sorted(store.results(), key=lambda kr: kr[0].grasp_index)]
    assert statuses == [Status.SUCCESS, Status.NO_CONTACT]


def test_a_file_naming_a_shipped_object_by_its_short_name_is_that_object(shifted_box, tmp_path):
    """A bench config's file of grasps of "mug" runs on the object built as "025_mug" (every trial was a
    planner_error, 'not the same object'); another object is still refused."""
    import dataclasses

    from manigrasp.errors import PlannerError

    asset = dataclasses.replace(shifted_box[0], name="025_mug")
    observation = Observation.from_asset(asset, np.eye(4))
    hand = hands.load("parallel_jaw")
    for named, same in (("mug", True), ("025_mug", True), ("048_hammer", False)):
        data = {"object": {"name": named}, "grasps": [{"pose": TOP_DOWN.tolist()}]}
        path = _write_json(tmp_path / f"{named}.json", data)
        if same:
            (candidate,) = FilePlanner(str(path)).plan(observation, hand, 1, np.random.default_rng(0))
            assert not candidate.invalid
        else:
            with pytest.raises(PlannerError, match="holds grasps of object '048_hammer', not '025_mug'"):
                FilePlanner(str(path)).plan(observation, hand, 1, np.random.default_rng(0))


def test_an_acronym_file_records_its_hand_and_claims_the_panda_only_for_the_panda(tmp_path):
    """write() always wrote gripper/type 'panda' and no hand; read() set no hand, so `evaluate` of a robotiq_2f85
    dataset ran silently on parallel_jaw."""
    from manigrasp.graspsets import GraspSet, ObjectRef

    for hand in ("robotiq_2f85", "panda", None):
        grasps = GraspSet(TOP_DOWN[None], np.array([0.03]), np.zeros(1), np.ones(1), frame="mesh", hand=hand,
                          hand_kind="parallel", object=ObjectRef(mesh="m.obj"))
        path = acronym.write(grasps, tmp_path / f"{hand}.h5")
        assert read(path).hand == hand
        with h5py.File(path) as handle:
            gripper = handle["gripper/type"][()].decode() if "gripper/type" in handle else None
        assert gripper == ("panda" if hand == "panda" else None)


def _npz(path: Path, **arrays) -> Path:
    np.savez(path, poses=np.eye(4)[None], **arrays)
    return path


def _h5_group_transforms(path: Path) -> Path:
    with h5py.File(path, "w") as f:
        f["grasps/transforms/a"] = np.eye(4)[None]
        f["object/file"] = "m.obj"
        f["object/scale"] = 1.0
    return path


@pytest.mark.parametrize(("make", "message"), [
    (lambda d: _write_json(d / "label_text.json", {"grasps": [{"pose": GOOD_POSE, "label": "success"}]}),
     "grasp 0: label must be an object"),
    (lambda d: _write_json(d / "label_list.json", {"grasps": [{"pose": GOOD_POSE, "label": [1, 2]}]}),
     "grasp 0: label must be an object"),
    (lambda d: _write_json(d / "label_value.json", {"grasps": [{"pose": GOOD_POSE, "label": {"s": [1, 2]}}]}),
     "grasp 0: label 's' must be a string, a number"),
    (lambda d: _write_json(d / "name.json", {"object": {"name": 25}, "grasps": [{"pose": GOOD_POSE}]}),
     "object name must be a string, got 25"),
    (lambda d: _write_json(d / "mesh.json", {"object": {"mesh": ["m.obj"]}, "grasps": [{"pose": GOOD_POSE}]}),
     "object mesh must be a string"),
    (lambda d: _write_json(d / "hand.json", {"hand": 3, "grasps": [{"pose": GOOD_POSE}]}), "hand must be a string"),
    (lambda d: _write_json(d / "kind.json", {"hand_kind": "Parallel", "grasps": [{"pose": GOOD_POSE}]}),
     "hand_kind must be one of parallel, dexterous, got 'Parallel'"),
    (lambda d: _write_json(d / "version.json", {"version": 2, "grasps": [{"pose": GOOD_POSE}]}),
     "version is 2; this manigrasp reads version 1"),
    (lambda d: _write_json(d / "both.json", {"grasps": [{"pose": GOOD_POSE, "position": [0, 0, 0.1]}]}),
     "grasp 0: give 'pose' or 'position' and 'quaternion', not both"),
    (lambda d: _npz(d / "frame.npz", frame=np.array(["object", "mesh"])), "'frame' must be one value, a string"),
    (lambda d: _npz(d / "framenum.npz", frame=np.array(1.0)), "'frame' must be one value, a string"),
    (lambda d: _npz(d / "scale.npz", object_scale=np.array(0.0)), "object scale must be a finite number > 0"),
    (lambda d: _npz(d / "kind.npz", hand_kind=np.array("Parallel")), "hand_kind must be one of parallel, dexterous"),
    (lambda d: _npz(d / "widths.npz", widths=np.array(["wide"])), "'widths' must be numbers"),
    (lambda d: d / "deep.json" if (d / "deep.json").write_text("[" * 100_000 + "]" * 100_000) else None,
     "JSON nested too deeply"),
    (lambda d: _write_json(d / "bigscore.json", {"grasps": [{"pose": GOOD_POSE, "score": 10**400}]}),
     "grasp 0: score must be a number a float can hold"),
    (lambda d: _write_json(d / "bigpos.json", {"grasps": [{"position": [10**400, 0, 0], "quaternion": [1, 0, 0, 0]}]}),
     "grasp 0: position must be numbers"),
    (lambda d: d / "digits.json" if (d / "digits.json").write_text('{"grasps": [{"score": ' + "9" * 5000 + "}]}")
     else None, "not valid JSON"),
    (lambda d: _write_json(d / "json.npz", {"grasps": [{"pose": GOOD_POSE}]}), "json.npz: not an NPZ file"),
    (lambda d: _npz(d / "width.npz", width=np.array([0.03])), "unknown array 'width' \\(did you mean 'widths'\\?\\)"),
    (lambda d: _npz(d / "both.npz", positions=np.zeros((1, 3)), quaternions=np.array([[1.0, 0, 0, 0]])),
     "give 'poses' or 'positions' and 'quaternions', not both"),
    (lambda d: _h5_group_transforms(d / "group.h5"), "'grasps/transforms' must be a dataset, not a group"),
    (lambda d: _h5(d / "name.h5", grasps__transforms=np.eye(4)[None], object__file="m.obj", object__scale=1.0,
                   object__manigrasp__name=np.array([1, 2])), "'object/manigrasp/name' must be one string"),
])
def test_malformed_grasp_files_give_the_one_line_grasp_file_error(tmp_path, make, message):
    """These raised TypeError, IndexError, AttributeError or ValueError tracebacks, or were read silently wrong
    (an NPZ object_scale of 0 as 1.0, version 2 as version 1, a pose's 'position' ignored, hand_kind 'Parallel'
    making every grasp invalid_grasp)."""
    path = make(tmp_path)
    with pytest.raises(GraspFileError, match=message) as info:
        read(path)
    assert "\n" not in str(info.value) and path.name in str(info.value)


def test_a_set_naming_its_hand_but_not_its_kind_is_not_transferred_across_kinds():
    """With transfer, a set made for a dexterous hand that did not state hand_kind ran on parallel_jaw."""
    from manigrasp.graspsets import GraspSet, placement_defect

    def defect(hand: str) -> str | None:
        grasps = GraspSet(TOP_DOWN[None], np.full(1, np.nan), np.zeros(1), np.zeros(1), hand=hand, source="g.json")
        return placement_defect(grasps, 0, "parallel_jaw", "parallel", 0.085, transfer=True)

    assert defect("inspire_right") == ("grasp 0 of g.json is a dexterous grasp (made for hand 'inspire_right'); "
                                       "hand 'parallel_jaw' is parallel")
    assert defect("panda") is None  # a parallel hand's set transfers, as before
    assert defect("my_own_hand") is None  # an unknown hand: its kind is not known, as before


def test_every_file_trial_names_the_files_grasp_index(tmp_path, monkeypatch):
    """Trials run the file's grasps best score first, so trial i is not the file's grasp i, and some invalid-grasp
    details named no index: results could not be joined back to the file's grasps."""
    from types import SimpleNamespace

    from manigrasp.bench import worker
    from manigrasp.bench.config import parse_config
    from manigrasp.bench.trials import groups

    nan = np.full((4, 4), np.nan).tolist()
    path = _write_json(tmp_path / "g.json", {"object": {"name": "004_sugar_box"}, "grasps": [
        {"pose": TOP_DOWN.tolist(), "score": 1.0, "joints": [[0.0], [0.0]]},  # joints on a parallel hand
        {"pose": nan, "score": 3.0}, {"pose": TOP_DOWN.tolist(), "score": 2.0, "preshape": 2.0}]})
    asset = catalog.build(catalog.shipped("004_sugar_box")).asset
    candidates = FilePlanner(str(path)).plan(Observation.from_asset(asset), hands.load("parallel_jaw"), 3,
                                             np.random.default_rng(0))
    assert [c.source for c in candidates] == ["file grasp 1", "file grasp 2", "file grasp 0"]
    # Each trial's detail begins with its grasp's source (the file order), whatever the trial's own detail.
    stub = SimpleNamespace(hand=hands.load("parallel_jaw"), hand_ctrlrange=lambda: None)
    monkeypatch.setattr(worker, "scene_for", lambda group: stub)
    (group,) = groups(parse_config({"objects": ["004_sugar_box"], "planners": [{"name": "file",
                      "params": {"path": str(path)}}], "grasps_per_object": 3, "protocol": "lift"}))
    plan = worker.Plan(tuple(candidates), None, 0.1, np.eye(4), None)
    details = [worker._run_trial(group, i, plan, None)[1].detail for i in range(3)]
    assert [d.split(": ")[0] for d in details] == ["file grasp 1", "file grasp 2", "file grasp 0"], details
    assert "NaN" in details[0] and "pre-shape" in details[1] and "joints" in details[2]
    assert worker.with_source("file grasp 4", "") == "file grasp 4"  # a trial without a detail of its own
