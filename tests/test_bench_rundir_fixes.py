"""A run directory refuses only what would mix two experiments: a run refused for a broken input leaves nothing
that blocks the corrected rerun, two spellings of one shipped object are one run, and a re-run that stores no
trial under other code records no mix of code versions."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest
import trimesh

from manigrasp.bench import rundir
from manigrasp.bench.config import parse_config
from manigrasp.bench.markdown import warning_lines
from manigrasp.bench.runner import run_benchmark
from manigrasp.errors import ConfigError

ONE = {"objects": ["004_sugar_box"], "planners": ["random"], "grasps_per_object": 1, "protocol": "lift"}


def test_a_broken_mesh_leaves_no_run_folder_and_the_fixed_rerun_runs(tmp_path):
    mesh = tmp_path / "text.obj"
    mesh.write_text("# no triangles here\nv 0 0 0\n")
    config = parse_config(dict(ONE, objects=[{"mesh": "text.obj", "name": "m_text"}]))
    with pytest.raises(ConfigError, match="no triangles"):
        run_benchmark(config, tmp_path / "run", progress=False, base=tmp_path)
    assert not (tmp_path / "run").exists()
    trimesh.creation.box((0.05, 0.05, 0.05)).export(mesh)
    summary = run_benchmark(config, tmp_path / "run", progress=False, base=tmp_path, in_process=True)
    assert summary.ran == 1 and (tmp_path / "run" / "run.json").exists()


def test_a_run_of_another_config_is_refused_before_objects_are_built(tmp_path, monkeypatch):
    from manigrasp.bench import runner

    rundir.prepare(tmp_path / "run", parse_config(ONE))
    monkeypatch.setattr(runner, "_prebuild_objects", lambda *a, **k: pytest.fail("built objects first"))
    with pytest.raises(ConfigError, match="different config"):
        run_benchmark(parse_config(dict(ONE, grasps_per_object=2)), tmp_path / "run", progress=False)


def test_an_interrupted_run_still_resumes(tmp_path):
    """A run killed after writing run.json and some trials runs only the rest when re-run."""
    config = parse_config(dict(ONE, grasps_per_object=2))
    run = tmp_path / "run"
    with pytest.raises(KeyboardInterrupt):
        run_benchmark(config, run, progress=False, in_process=True,
                      on_result=lambda key, result: (_ for _ in ()).throw(KeyboardInterrupt))
    summary = run_benchmark(config, run, progress=False, in_process=True)
    assert (summary.already_done, summary.ran) == (1, 1)
    assert len(rundir.read_meta(run)["resumed"]) == 1


def test_a_shipped_objects_short_name_is_the_same_run(tmp_path):
    run = tmp_path / "run"
    rundir.prepare(run, parse_config(dict(ONE, objects=["mug"])))
    assert rundir.read_meta(run)["config"]["objects"][0]["name"] == "025_mug"  # as the trial ids name it
    rundir.prepare(run, parse_config(dict(ONE, objects=["025_mug"])))
    with pytest.raises(ConfigError, match="different config"):
        rundir.prepare(run, parse_config(dict(ONE, objects=["004_sugar_box"])))


def test_a_run_json_with_an_unresolved_short_name_still_resumes(tmp_path):
    """run.json written before names were resolved records "mug": it resumes under either spelling."""
    run = tmp_path / "run"
    rundir.prepare(run, parse_config(dict(ONE, objects=["025_mug"])))
    meta = rundir.read_meta(run)
    meta["config"]["objects"][0]["name"] = "mug"
    (run / "run.json").write_text(json.dumps(meta))
    rundir.prepare(run, parse_config(dict(ONE, objects=["025_mug"])))
    rundir.prepare(run, parse_config(dict(ONE, objects=["mug"])))
    with pytest.raises(ConfigError, match="different config"):
        rundir.prepare(run, parse_config(dict(ONE, objects=["004_sugar_box"])))


def test_rerunning_a_finished_run_under_other_code_records_no_mix(tmp_path):
    config = parse_config(ONE)
    run = tmp_path / "run"
    run_benchmark(config, run, progress=False, in_process=True)
    meta = json.loads((run / "run.json").read_text())
    meta["versions"]["manigrasp"] = "0.0.1"
    (run / "run.json").write_text(json.dumps(meta))
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        summary = run_benchmark(config, run, progress=False, in_process=True)
    assert summary.ran == 0
    meta = rundir.read_meta(run)
    assert "resumed_with_other_code" not in meta and len(meta["resumed"]) == 1
    assert not any("other code" in line for line in warning_lines(meta))


def test_a_refused_config_names_the_field_of_an_object_or_planner_that_differs(tmp_path):
    """An object's mass or a planner's parameter that differs was shown as the whole list cut at 60 characters
    (`objects: [{"name": "025_mug", "mesh": null, "ycb": null, "scale": ... -> [{"name": ...`), the value that
    differs cut off."""
    rundir.prepare(tmp_path / "run", parse_config(dict(ONE, objects=["025_mug", "011_banana"])))
    heavier = parse_config(dict(ONE, objects=["025_mug", {"name": "011_banana", "mass": 0.3}]))
    with pytest.raises(ConfigError, match=r"\(objects\[1\]\.mass: null -> 0\.3\)"):
        rundir.check(tmp_path / "run", heavier)
    more = parse_config(dict(ONE, objects=["025_mug", "011_banana", "004_sugar_box"]))
    with pytest.raises(ConfigError, match=r"objects: \[\{"):  # lists of other lengths still compare whole
        rundir.check(tmp_path / "run", more)


@pytest.mark.slow
def test_a_mesh_edited_during_the_run_gives_no_trial_of_another_object(tmp_path, monkeypatch):
    """Workers build each object from its mesh file when they first need it: a mesh edited after the run had
    built it (and recorded its hash in run.json) was run by every worker started later, trials of two objects
    under one name. Now a worker whose build differs refuses it: the trials are harness faults naming the change
    (left out of every rate; the resume is refused, the mesh having changed)."""
    from manigrasp.bench import runner
    from manigrasp.bench.store import ResultsStore

    mesh = tmp_path / "part.stl"
    trimesh.creation.box((0.05, 0.04, 0.03)).export(mesh)
    built = runner._prebuild_objects

    def build_then_edit(*args, **kwargs):
        keys = built(*args, **kwargs)
        trimesh.creation.box((0.07, 0.04, 0.03)).export(mesh)  # edited once the main process built it
        return keys

    monkeypatch.setattr(runner, "_prebuild_objects", build_then_edit)
    config = parse_config(dict(ONE, objects=[{"mesh": str(mesh), "name": "part"}], grasps_per_object=2))
    run_benchmark(config, tmp_path / "run", progress=False)
    with ResultsStore(tmp_path / "run" / "results.sqlite") as store:
        rows = list(store.rows())
    assert len(rows) == 2 and all(r["status"] == "harness_fault" for r in rows), [r["status"] for r in rows]
    assert all("build differs from the run" in r["detail"] for r in rows)


def test_a_mesh_file_gone_since_the_run_started_is_named_as_gone_not_changed(tmp_path):
    """A resume whose mesh file had been moved away said the file 'changed since this run started; use another
    --out': another --out cannot build a missing mesh; putting the file back resumes the run."""
    mesh = tmp_path / "part.stl"
    trimesh.creation.box((0.05, 0.04, 0.03)).export(mesh)
    config = parse_config(dict(ONE, objects=[{"mesh": str(mesh), "name": "part"}]))
    _moved_away_and_back(tmp_path, config, mesh, "mesh file of part is missing or unreadable .* put it back")


def _moved_away_and_back(tmp_path, config, path, refusal: str) -> None:
    """A run of `config` started, `path` moved away: resuming is refused with `refusal`; moved back: it resumes."""
    rundir.prepare(tmp_path / "run", config)
    moved = path.rename(tmp_path / f"moved{path.suffix}")
    with pytest.raises(ConfigError, match=refusal):
        rundir.check(tmp_path / "run", config)
    moved.rename(path)
    assert rundir.check(tmp_path / "run", config) is not None


def test_a_grasp_file_gone_since_the_run_started_is_named_as_gone_not_changed(tmp_path):
    """As for a mesh: a `file` planner's grasp file moved away was 'changed since this run started'."""
    grasps = tmp_path / "g.json"
    grasps.write_text(json.dumps({"object": {"name": "004_sugar_box"}, "grasps": [{"pose": np.eye(4).tolist()}]}))
    config = parse_config(dict(ONE, planners=[{"name": "file", "params": {"path": str(grasps)}}]))
    _moved_away_and_back(tmp_path, config, grasps,
                         "grasp file of planner 'file' is missing or unreadable .* put it back")


def test_a_run_recorded_before_a_scene_parameter_existed_keeps_the_physics_it_ran_with(tmp_path):
    """A run.json written before `scene.ccd_tolerance` was recorded ran at MuJoCo's default 1e-6, not today's 1e-9:
    read back (resume check, replay, report), its scene says 1e-6; resuming it under today's defaults is refused
    with the override that resumes it, and that override (written 1e-6, which YAML 1.1 reads as a string) does."""
    from manigrasp.sim.config import LEGACY_SCENE, SceneConfig

    run = tmp_path / "run"
    rundir.prepare(run, parse_config(ONE))
    meta = json.loads((run / "run.json").read_text())
    assert meta["config"]["scene"]["ccd_tolerance"] == SceneConfig().ccd_tolerance == 1e-9
    del meta["config"]["scene"]["ccd_tolerance"]  # as a run.json before 645f8e2
    (run / "run.json").write_text(json.dumps(meta))
    assert rundir.load_meta(run)["config"]["scene"]["ccd_tolerance"] == LEGACY_SCENE["ccd_tolerance"] == 1e-6
    with pytest.raises(ConfigError, match=r"scene.ccd_tolerance: 1e-06 -> 1e-09.*give scene.ccd_tolerance=1e-06"):
        rundir.check(run, parse_config(ONE))
    assert rundir.check(run, parse_config(ONE, ["scene.ccd_tolerance=1e-6"])) is not None
    with pytest.raises(ConfigError, match="expected a number"):
        parse_config(ONE, ["scene.ccd_tolerance=tiny"])
