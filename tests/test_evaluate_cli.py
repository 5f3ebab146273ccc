"""`manigrasp evaluate`: input errors are one line and exit 2 before any trial; the options its messages name exist."""

from __future__ import annotations

import json
import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import trimesh

from manigrasp.bench.config import MAX_GRASPS_PER_OBJECT
from manigrasp.cli import main
from manigrasp.graspsets import native, placement_defect, read

# A top-down grasp (z approach = -z, y closing = +y) 1.5 cm below the top of a 4 cm cube.
TOP_DOWN = [[-1.0, 0, 0, 0], [0, 1, 0, 0], [0, 0, -1, 0.005], [0, 0, 0, 1]]


def _grasp_file(path: Path, n: int = 1, **top) -> Path:
    path.write_text(json.dumps({"hand": "parallel_jaw", **top, "grasps": [{"pose": TOP_DOWN}] * n}))
    return path


@pytest.fixture
def captured(monkeypatch) -> list:
    """Stand-ins for the run and the report: `evaluate`'s config is captured, no trial is simulated."""
    import manigrasp.bench.runner
    import manigrasp.cli.report

    configs: list = []

    def run_benchmark(config, out, **_):
        configs.append(config)
        return SimpleNamespace(ran=0, already_done=0, seconds=0.0)

    monkeypatch.setattr(manigrasp.bench.runner, "run_benchmark", run_benchmark)
    monkeypatch.setattr(manigrasp.cli.report, "print_report", lambda *_, **__: 0)
    return configs


def _error(capsys, argv: list[str]) -> str:
    """Run the CLI on `argv`, which must fail as an input error: exit 2 and one line on stderr."""
    capsys.readouterr()  # what earlier runs printed
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("manigrasp: error: ") and "\n" not in err, err
    return err


def test_a_file_without_grasps_is_refused_not_run_as_one_made_up_trial(tmp_path, capsys, captured):
    path = _grasp_file(tmp_path / "empty.json", n=0, object={"name": "025_mug"})
    err = _error(capsys, ["evaluate", str(path), "--out", str(tmp_path / "run"), "--quiet"])
    assert "holds no grasps" in err and "empty.json" in err
    assert not captured and not (tmp_path / "run").exists()


def test_a_file_of_too_many_grasps_names_its_grasp_count_not_a_setting(tmp_path, capsys, captured):
    path = tmp_path / "many.npz"
    np.savez(path, poses=np.tile(np.asarray(TOP_DOWN), (MAX_GRASPS_PER_OBJECT + 1, 1, 1)),
             object_name=np.array("025_mug"))
    err = _error(capsys, ["evaluate", str(path), "--out", str(tmp_path / "run"), "--quiet"])
    assert f"holds {MAX_GRASPS_PER_OBJECT + 1} grasps" in err and "grasps_per_object" not in err
    assert not captured
    # Up to the limit, every grasp of the file is one trial.
    np.savez(path, poses=np.tile(np.asarray(TOP_DOWN), (3, 1, 1)), object_name=np.array("025_mug"))
    assert main(["evaluate", str(path), "--out", str(tmp_path / "run"), "--quiet"]) == 0
    assert captured[0].grasps_per_object == 3


@pytest.mark.parametrize("jobs", ["0", "-3"])
def test_jobs_below_one_is_refused_like_bench(tmp_path, capsys, captured, jobs):
    path = _grasp_file(tmp_path / "g.json", object={"name": "025_mug"})
    err = _error(capsys, ["evaluate", str(path), "--out", str(tmp_path / "run"), "--jobs", jobs, "--quiet"])
    assert f"--jobs must be >= 1, got {jobs}" in err and not captured


def test_non_finite_widths_are_invalid_grasps_and_an_absent_width_is_not_given(tmp_path):
    rows = [{"pose": TOP_DOWN}, {"pose": TOP_DOWN, "width": None}, {"pose": TOP_DOWN, "width": 0.03},
            {"pose": TOP_DOWN, "width": math.nan}, {"pose": TOP_DOWN, "width": math.inf},
            {"pose": TOP_DOWN, "width": -math.inf}]
    path = tmp_path / "w.json"
    path.write_text(json.dumps({"grasps": rows}))  # json writes NaN / Infinity, as Python's json reads them
    for grasps in (read(path), read(native.write(read(path), tmp_path / "w.npz")),
                   read(native.write(read(path), tmp_path / "again.json"))):
        defects = [placement_defect(grasps, i, "parallel_jaw", "parallel", 0.08) for i in range(len(rows))]
        assert defects[:3] == [None, None, None], grasps.source
        for defect in defects[3:]:
            assert defect and "width" in defect and "not a finite number" in defect, (grasps.source, defect)
    # An NPZ's NaN width is "not given" (the documented layout); an infinite one is an invalid grasp.
    np.savez(tmp_path / "n.npz", poses=np.tile(np.asarray(TOP_DOWN), (2, 1, 1)), widths=np.array([np.nan, np.inf]))
    grasps = read(tmp_path / "n.npz")
    assert placement_defect(grasps, 0, "parallel_jaw", "parallel", 0.08) is None
    assert "not a finite number" in placement_defect(grasps, 1, "parallel_jaw", "parallel", 0.08)


def test_grasps_of_another_object_are_refused_naming_an_option_evaluate_has(tmp_path, capsys, captured):
    path = _grasp_file(tmp_path / "mug.json", object={"name": "025_mug"})
    out = ["--out", str(tmp_path / "run"), "--quiet"]
    err = _error(capsys, ["evaluate", str(path), "--object", "tennis_ball", *out])
    assert "'025_mug'" in err and "tennis_ball" in err and "--any-object" in err and "check_object" not in err
    assert not captured
    assert main(["evaluate", str(path), "--object", "tennis_ball", "--any-object", *out]) == 0
    assert captured[-1].planners[0].params["check_object"] is False
    # The file's object under its own name or another: the planner's params (the run's identity) are as before.
    for other in ([], ["--object", "mug"]):
        assert main(["evaluate", str(path), *other, *out]) == 0
        assert "check_object" not in captured[-1].planners[0].params
    # A file naming its object "mug" is built as "025_mug": the same object, so the planner checks no name
    # (it compares names, and would record every trial planner_error).
    alias = _grasp_file(tmp_path / "alias.json", object={"name": "mug"})
    assert main(["evaluate", str(alias), *out]) == 0
    assert captured[-1].planners[0].params["check_object"] is False


def test_a_mesh_object_named_like_a_shipped_one_is_given_a_name_with_name(tmp_path, capsys, captured):
    mesh = tmp_path / "cube.obj"
    trimesh.creation.box(extents=(0.04, 0.04, 0.04)).export(mesh)
    path = _grasp_file(tmp_path / "mug.json", object={"name": "025_mug"})
    out = ["--out", str(tmp_path / "run"), "--quiet"]
    err = _error(capsys, ["evaluate", str(path), "--object", str(mesh), *out])
    assert "--name" in err and "--any-object" in err  # both options exist: the advice can be followed
    assert main(["evaluate", str(path), "--object", str(mesh), "--name", "my_cube", "--any-object", *out]) == 0
    entry = captured[-1].objects[0]
    assert entry.name == "my_cube" and Path(entry.mesh) == mesh.resolve()
    # A file that names no object: the mesh's name is --name, else the mesh file's stem; nothing to refuse.
    bare = _grasp_file(tmp_path / "bare.json")
    assert main(["evaluate", str(bare), "--object", str(mesh), *out]) == 0
    assert captured[-1].objects[0].name == "cube"
    assert main(["evaluate", str(bare), "--object", str(mesh), "--name", "my_cube", *out]) == 0
    assert captured[-1].objects[0].name == "my_cube"
    err = _error(capsys, ["evaluate", str(bare), "--object", "tennis_ball", "--name", "x", *out])
    assert "--name" in err and "mesh" in err


@pytest.mark.slow
def test_a_grasp_with_a_nan_width_runs_as_invalid_grasp(tmp_path):
    """End to end on the parallel jaw: the NaN-width grasp is recorded invalid_grasp, not run."""
    from manigrasp.bench.store import ResultsStore
    from manigrasp.protocol.result import Status

    path = tmp_path / "nan_width.json"
    path.write_text(json.dumps({"hand": "parallel_jaw", "object": {"name": "025_mug"},
                                "grasps": [{"pose": TOP_DOWN, "width": math.nan}]}))
    assert main(["evaluate", str(path), "--out", str(tmp_path / "run"), "--quiet"]) == 0
    with ResultsStore(tmp_path / "run" / "results.sqlite") as store:
        results = [r for _, r in store.results()]
    assert [r.status for r in results] == [Status.INVALID_GRASP] and "width" in results[0].detail


def test_scale_of_a_shipped_object_and_a_mass_of_zero_are_refused_not_dropped(tmp_path, capsys, captured):
    """--scale 0.5 on a shipped object ran at its real size, recording scale 1.0; --mass 0 was dropped (taken as
    not given)."""
    path = _grasp_file(tmp_path / "g.json", object={"name": "025_mug"})
    out = ["--out", str(tmp_path / "run"), "--quiet"]
    err = _error(capsys, ["evaluate", str(path), "--scale", "0.5", *out])
    assert "--scale applies to a mesh --object; '025_mug' is a shipped object" in err
    assert "mass must be > 0, got 0" in _error(capsys, ["evaluate", str(path), "--mass", "0", *out])
    mesh = tmp_path / "box.obj"
    trimesh.creation.box(extents=(0.04, 0.04, 0.04)).export(mesh)
    box = _grasp_file(tmp_path / "box.json", object={"name": "box", "mesh": mesh.name})
    assert "scale must be > 0, got 0" in _error(capsys, ["evaluate", str(box), "--scale", "0", *out])
    assert not captured
    assert main(["evaluate", str(box), "--scale", "0.5", "--mass", "0.3", *out]) == 0
    assert (captured[0].objects[0].scale, captured[0].objects[0].mass) == (0.5, 0.3)


def test_the_help_says_what_a_nan_width_means_in_each_format():
    """It said a NaN width is invalid; an NPZ NaN width is 'not given'."""
    from manigrasp.cli.evaluate import FORMATS_HELP

    text = " ".join(FORMATS_HELP.split())
    assert "NaN: invalid)" not in text
    assert '"width" (jaw opening [m]; absent or null: not given; NaN or Infinity: invalid_grasp)' in text
    assert "widths (NaN: not given; +-inf: invalid_grasp)" in text


@pytest.mark.parametrize("extra", [[], ["--any-object"]])
def test_an_object_path_that_is_no_mesh_file_is_named_as_such(tmp_path, capsys, captured, extra):
    """A mistyped mesh path was taken for an object name: 'holds grasps of object 025_mug, not /x/missing.obj'
    (whose advice, --any-object, then gave "unknown object '/x/missing.obj'"); a folder likewise."""
    path = _grasp_file(tmp_path / "g.json", object={"name": "025_mug"})
    (tmp_path / "folder.obj").mkdir()
    for given, phrase in ((tmp_path / "missing.obj", "no such mesh file"), ("missing.stl", "no such mesh file"),
                          (tmp_path / "folder.obj", "a folder, not a mesh file")):
        err = _error(capsys, ["evaluate", str(path), "--out", str(tmp_path / "run"), "--object", str(given), *extra])
        assert f"--object {given}: {phrase}" in err, err
    assert not captured
