"""Reliability of the harness under adversarial input (issue 14): nothing lost, nothing mislabelled.

Bad input is a one-line `ConfigError` (CLI exit 2) before anything is written; a planner or trial that
fails, hangs or kills its worker is a recorded status and the run goes on.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import trimesh

from manigrasp.bench import rundir
from manigrasp.bench.config import MAX_GRASPS_PER_OBJECT, NamedEntry, labels, load_config, parse_config
from manigrasp.bench.runner import max_jobs, run_benchmark
from manigrasp.bench.store import ResultsStore
from manigrasp.cli import build_parser, main
from manigrasp.errors import ConfigError, PlannerError
from manigrasp.protocol.result import Status

TESTS = Path(__file__).parent
ONE = {"objects": ["004_sugar_box"], "planners": ["random"], "grasps_per_object": 1, "protocol": "lift"}


@pytest.fixture(autouse=True)
def _user_modules_importable(monkeypatch):
    monkeypatch.syspath_prepend(str(TESTS))
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(TESTS), os.environ.get("PYTHONPATH", "")]))


def _rows(run_dir: Path) -> list[dict]:
    with ResultsStore(run_dir / "results.sqlite") as store:
        return list(store.rows())


# ---------------------------------------------------------------- config values
@pytest.mark.parametrize(("override", "phrase"), [
    ("grasps_per_object=2.5", "grasps_per_object: expected an integer, got a number"),
    ("grasps_per_object=abc", "grasps_per_object: expected an integer, got a string"),
    ("grasps_per_object=true", "grasps_per_object: expected an integer, got a boolean"),
    (f"grasps_per_object={MAX_GRASPS_PER_OBJECT + 1}", f"must be in 1..{MAX_GRASPS_PER_OBJECT}"),
    ("seed=abc", "seed: expected an integer, got a string"),
    ("seed=1e30", "seed: expected an integer, got a string"),  # YAML 1.1 reads 1e30 as a string
    ("seed=1.0e+30", "seed: expected an integer, got a number"),
    ("seed=-1", r"seed must be an integer in 0..2\*\*63-1"),
    ("name=[1,2]", "name: expected a string, got a list"),
    ("objects=[5]", r"objects\[0\]: expected a mapping, got an integer"),
    ("hands=[{a: 1}]", r"hands\[0\]: expected a string, got a mapping"),
    ("planners=[{name: random, params: [1,2]}]", r"params: expected a mapping, got a list"),
    ("scene=5", "scene: expected a mapping, got an integer"),
    ("scene.gravity=[0, 0]", "expected a list of 3 values"),
    ("trial_timeout_s=.nan", "expected a finite number"),
    ("objects=[{name: mug, mass: -1}]", "mass must be > 0, got -1"),
    ("objects=[{name: mug, mass: 0}]", "mass must be > 0, got 0"),
    ("objects=[{name: mug, mass: heavy}]", "mass: expected a number, got a string"),
    ("objects=[{name: mug, density: -5}]", "density must be > 0"),
    ("objects=[mug, mug]", "listed twice"),
    ("objects=[mug, 025_mug]", "both named '025_mug'"),
    ("hands=[panda, panda]", "hand panda is listed twice"),
    ("planners=[random, random]", "listed twice"),
    ("planners=[{name: random, params: {spread: 0.2}}, {name: random, params: {spread: 0.2}}]", "listed twice"),
    ("grasps_per_objct=3", "did you mean 'grasps_per_object'"),  # the hints stay
])
def test_wrong_types_ranges_and_duplicates_are_one_line_errors(override, phrase):
    from manigrasp.bench.trials import groups

    with pytest.raises(ConfigError, match=phrase) as info:
        groups(parse_config({"objects": ["mug"]}, [override]))
    assert "\n" not in str(info.value)


def test_list_fields_take_one_value_alike():
    config = parse_config({}, ["objects=mug", "hands=panda", "planners=random", "observation=point_cloud"])
    assert [o.name for o in config.objects] == ["mug"] and config.hands == ("panda",)
    assert [p.name for p in config.planners] == ["random"] and config.observation == ("point_cloud",)


def test_binary_garbage_and_deep_nesting_are_config_errors(tmp_path):
    garbage = tmp_path / "garbage.yaml"
    garbage.write_bytes(bytes(range(256)) * 4)
    with pytest.raises(ConfigError, match="not a text"):
        load_config(garbage)
    deep = tmp_path / "deep.yaml"
    deep.write_text("objects: " + "[" * 5000 + "]" * 5000 + "\n")
    with pytest.raises(ConfigError, match="nested too deeply|not valid YAML"):
        load_config(deep)
    with pytest.raises(ConfigError, match="nested more than"):
        nested: object = 1
        for _ in range(50):
            nested = [nested]
        parse_config({"objects": ["mug"], "planners": [{"name": "random", "params": {"x": nested}}]})


def test_cli_bad_value_exits_2_and_writes_nothing(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["bench", "quick", "--out", str(out), "grasps_per_object=2.5"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "expected an integer" in err
    assert not out.exists()


def test_overrides_anywhere_on_the_command_line():
    args = build_parser().parse_args(["bench", "--out", "X", "quick", "grasps_per_object=1", "--jobs", "2", "seed=3"])
    assert args.config == "quick" and args.overrides == ["grasps_per_object=1", "seed=3"] and args.jobs == 2


# ---------------------------------------------------------------- trial identity
def test_labels_are_readable_and_distinct():
    side = [NamedEntry("faulty_planners:TopDown", {"lift": 0.0}), NamedEntry("faulty_planners:TopDown", {"lift": 0.04})]
    assert labels(side) == ("TopDown[lift=0.0]", "TopDown[lift=0.04]")
    assert labels([NamedEntry("antipodal"), NamedEntry("random")]) == ("antipodal", "random")
    assert labels([NamedEntry("random"), NamedEntry("random", {"spread": 0.2})]) == ("random", "random[spread=0.2]")
    assert labels([NamedEntry("a:P"), NamedEntry("b:P")]) == ("P[a]", "P[b]")
    paths = labels([NamedEntry("a:P", {"model": "../x/y"}), NamedEntry("a:P", {"model": "z"})])
    assert "/" not in paths[0] and paths[1] == "P[model=z]" and paths[0] != paths[1]  # trial ids stay paths
    with pytest.raises(ConfigError, match="listed twice"):
        labels([NamedEntry("random", {"spread": 0.2}), NamedEntry("random", {"spread": 0.2})])


@pytest.mark.slow
def test_one_planner_twice_with_different_params_gives_two_sets_of_trials(tmp_path):
    data = dict(ONE, grasps_per_object=2, planners=[{"name": "faulty_planners:TopDown", "params": {"lift": 0.0}},
                                                    {"name": "faulty_planners:TopDown", "params": {"lift": 0.04}}])
    summary = run_benchmark(parse_config(data), tmp_path / "run", progress=False)
    rows = _rows(tmp_path / "run")
    assert summary.total == summary.ran == len(rows) == 4
    assert {r["planner"] for r in rows} == {"TopDown[lift=0.0]", "TopDown[lift=0.04]"}
    heights = {r["planner"]: r["grasp_z_m"] for r in rows}  # the variants really ran their own params
    assert heights["TopDown[lift=0.04]"] - heights["TopDown[lift=0.0]"] == pytest.approx(0.04, abs=1e-9)


@pytest.mark.slow
def test_worker_processes_and_in_process_give_the_same_rows(tmp_path):
    config = parse_config(dict(ONE, planners=["antipodal"], grasps_per_object=2))
    run_benchmark(config, tmp_path / "pool", progress=False)
    run_benchmark(config, tmp_path / "here", progress=False, in_process=True)
    timing = {"wall_time_s", "planning_time_s", "plan_time_s"}
    pool, here = ([{k: v for k, v in r.items() if k not in timing} for r in _rows(tmp_path / d)]
                  for d in ("pool", "here"))
    assert pool == here and len(pool) == 2


@pytest.mark.slow
def test_a_rerun_with_other_values_names_the_keys(tmp_path):
    run_benchmark(parse_config(ONE), tmp_path / "run", progress=False)
    meta = json.loads((tmp_path / "run" / "run.json").read_text())
    assert len(meta["identity"]["config_sha256"]) == 64
    with pytest.raises(ConfigError, match=r"seed: 0 -> 7; trial_timeout_s: 120.0 -> 60.0"):
        run_benchmark(parse_config(ONE, ["seed=7", "trial_timeout_s=60"]), tmp_path / "run", progress=False)
    with pytest.raises(ConfigError, match=r"protocol.name: \"lift\" -> \"standard\""):
        run_benchmark(parse_config(ONE, ["protocol=standard"]), tmp_path / "run", progress=False)


@pytest.mark.parametrize("damage", ["delete", "garbage", "list", "directory"])
@pytest.mark.slow
def test_results_without_a_readable_run_json_are_not_adopted(tmp_path, damage):
    run_benchmark(parse_config(ONE), tmp_path / "run", progress=False)
    meta = tmp_path / "run" / "run.json"
    meta.unlink()
    if damage == "garbage":
        meta.write_bytes(b"\x00\xff{")
    elif damage == "list":
        meta.write_text("[1, 2]")
    elif damage == "directory":
        meta.mkdir()
    with pytest.raises(ConfigError, match="no run.json|not readable run metadata|not run metadata"):
        run_benchmark(parse_config(ONE, ["seed=7"]), tmp_path / "run", progress=False)
    assert len(_rows(tmp_path / "run")) == 1


@pytest.mark.parametrize("damage", ["garbage", "truncated"])
@pytest.mark.slow
def test_a_damaged_results_store_is_a_one_line_error(tmp_path, damage):
    run_benchmark(parse_config(ONE), tmp_path / "run", progress=False)
    store = tmp_path / "run" / "results.sqlite"
    data = store.read_bytes()
    for extra in tmp_path.glob("run/results.sqlite-*"):
        extra.unlink()
    store.write_bytes(b"garbage " * 512 if damage == "garbage" else data[:1000])
    with pytest.raises(ConfigError, match="not a readable results store"):
        run_benchmark(parse_config(ONE), tmp_path / "run", progress=False)


@pytest.mark.slow
def test_an_edited_mesh_file_is_refused_on_resume(tmp_path):
    mesh = tmp_path / "block.stl"
    trimesh.creation.box((0.05, 0.05, 0.05)).export(mesh)
    config = dict(ONE, objects=[{"mesh": str(mesh), "name": "block_reliability"}])
    run_benchmark(parse_config(config), tmp_path / "run", progress=False)
    trimesh.creation.box((0.05, 0.05, 0.06)).export(mesh)
    with pytest.raises(ConfigError, match="mesh file of block_reliability changed"):
        run_benchmark(parse_config(config), tmp_path / "run", progress=False)


def test_resuming_with_other_code_warns_and_is_recorded(tmp_path):
    """A default or the physics may change between code versions: a run resumed by other code that runs trials
    says so (a warning naming what changed) and run.json keeps the record with how many trials that code stored;
    the same code resumes silently."""
    import warnings

    config = parse_config(dict(ONE, grasps_per_object=2))
    rundir.prepare(tmp_path / "run", config)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        rundir.prepare(tmp_path / "run", config)  # same code: no warning
    meta_path = tmp_path / "run" / "run.json"
    meta = json.loads(meta_path.read_text())
    meta["versions"]["manigrasp"] = "0.0.1"
    meta["git_commit"] = "0123456789abcdef0123"
    meta_path.write_text(json.dumps(meta))
    with pytest.warns(RuntimeWarning, match=r"started by other code \(.*manigrasp 0\.0\.1 -> "):
        run_benchmark(config, tmp_path / "run", progress=False, in_process=True)
    record = json.loads(meta_path.read_text())["resumed_with_other_code"]
    assert len(record) == 1 and any(c.startswith("manigrasp 0.0.1 -> ") for c in record[0]["changes"])
    assert record[0]["trials"] == 2
    if rundir.git_commit():
        assert any(c.startswith("git commit 0123456789ab -> ") for c in record[0]["changes"])


def test_out_pointing_at_a_file_is_a_config_error(tmp_path):
    (tmp_path / "file").write_text("x")
    with pytest.raises(ConfigError, match="is a file"):
        run_benchmark(parse_config(ONE), tmp_path / "file", progress=False)


@pytest.mark.slow
def test_a_second_process_on_the_same_run_directory_is_refused(tmp_path):
    with rundir.locked(tmp_path / "run"):
        with pytest.raises(ConfigError, match=rf"in use by pid {os.getpid()} on "):
            run_benchmark(parse_config(ONE), tmp_path / "run", progress=False)
    assert not (tmp_path / "run" / "results.sqlite").exists()
    assert run_benchmark(parse_config(ONE), tmp_path / "run", progress=False).ran == 1  # released


# ---------------------------------------------------------------- faults are statuses
def test_a_perception_failure_is_recorded_for_its_group(monkeypatch):
    from manigrasp.bench import worker
    from manigrasp.bench.trials import groups
    from manigrasp.perception import pipeline

    def not_in_view(*args, **kwargs):
        raise ConfigError("fewer than 10 object points are left (the object is not in view)")

    monkeypatch.setattr(pipeline, "perceive", not_in_view)
    group = groups(parse_config(dict(ONE, observation="estimated_pose")))[0]
    plan = worker.plan_group(group)
    assert plan.status is Status.PLANNER_ERROR and "perception failed" in plan.error and "not in view" in plan.error
    key, result = worker.run_trial(group, 0, plan)
    assert result.status is Status.PLANNER_ERROR and "not in view" in result.detail


@pytest.mark.slow
def test_a_harness_bug_is_harness_fault_with_its_traceback(tmp_path):
    run_benchmark(parse_config(dict(ONE, protocol="faulty_planners:raising_protocol")), tmp_path / "run",
                  progress=False)
    (row,) = _rows(tmp_path / "run")
    assert row["status"] == "harness_fault" and "RuntimeError: protocol bug" in row["detail"]
    assert "faulty_planners.py" in row["detail"]  # the traceback's last lines


def test_a_pose_just_off_a_rotation_is_invalid_grasp_not_an_exception(tmp_path):
    from manigrasp.objects import build_object
    from manigrasp.protocol import PROTOCOLS, settle_object
    from manigrasp.protocol.grasp import Grasp, check_grasp
    from manigrasp.sim import build_scene

    asset = build_object(trimesh.creation.box((0.05,) * 3), name="box_rel", mass=0.3, cache_root=tmp_path).asset
    scene = build_scene("parallel_jaw", asset)
    rest = settle_object(scene)
    pose = np.diag([1.0, -1.0, -1.0, 1.0])
    pose[:3, 3] = rest[:3, 3]
    pose[0, 1] += 2e-5  # beyond the one rigidity tolerance (geometry.RIGID_TOLERANCE): refused before the scene
    assert "rotation" in check_grasp(Grasp(pose))
    result = PROTOCOLS.load("lift").run(scene, pose, np.random.default_rng(0), object_pose=rest)
    assert result.status is Status.INVALID_GRASP and "rotation" in result.detail
    from types import SimpleNamespace

    odd = SimpleNamespace(pose=np.diag([1.0, -1.0, -1.0, 1.0]), preshape="abc")
    result = PROTOCOLS.load("lift").run(scene, odd, np.random.default_rng(0), object_pose=rest)
    assert result.status is Status.INVALID_GRASP and "cannot be read" in result.detail


def test_config_code_of_the_wrong_kind_is_refused_before_it_is_called(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    evil = dict(ONE, planners=[{"name": "os:system", "params": {"command": "touch PWNED"}}])
    with pytest.raises(PlannerError, match="not called"):
        run_benchmark(parse_config(evil), tmp_path / "run", progress=False)
    with pytest.raises(ConfigError, match="not called"):
        run_benchmark(parse_config(dict(ONE, hands=["os:getcwd"])), tmp_path / "run", progress=False)
    with pytest.raises(ConfigError, match="not called"):
        run_benchmark(parse_config(dict(ONE, protocol="os:getcwd")), tmp_path / "run", progress=False)
    with pytest.raises(ConfigError, match="building it raised RuntimeError: no hand today"):
        run_benchmark(parse_config(dict(ONE, hands=["faulty_planners:raising_hand"])), tmp_path / "run",
                      progress=False)
    assert not (tmp_path / "PWNED").exists() and not (tmp_path / "run").exists()


FAULTY = ["Exits", "Segfaults", "CallsSysExit", "WideWidth", "NoPreshape", "FactoryRaises", "RaisesCancelled",
          "UnreadableError"]


@pytest.mark.slow
def test_crashing_and_malformed_planners_are_recorded_and_the_run_completes(tmp_path, capsys):
    # (A CancelledError, a BaseException, and an exception whose text cannot be read were harness faults, left out
    # of the planner's rate; a candidate of an unpicklable subclass was one too.)
    planners = [f"faulty_planners:{name}" for name in FAULTY] + ["random", "faulty_planners:LocalSubclass"]
    data = dict(ONE, planners=planners)
    summary = run_benchmark(parse_config(data), tmp_path / "run", jobs=1000, progress=False)
    assert f"capped at the {max_jobs()} cores" in capsys.readouterr().err
    rows = {r["planner"]: r for r in _rows(tmp_path / "run")}
    assert summary.ran == len(rows) == len(FAULTY) + 2
    assert rows["LocalSubclass"]["status"] not in ("planner_error", "harness_fault"), rows["LocalSubclass"]["detail"]
    assert "CancelledError" in rows["RaisesCancelled"]["detail"]
    assert "its message could not be read" in rows["UnreadableError"]["detail"]
    for name in FAULTY:
        assert rows[name]["status"] == "planner_error", (name, rows[name]["detail"])
    assert "exited with code 3" in rows["Exits"]["detail"] and "SIGSEGV" in rows["Segfaults"]["detail"]
    assert "SystemExit" in rows["CallsSysExit"]["detail"] and "'wide'" in rows["WideWidth"]["detail"]
    assert "preshape is None" in rows["NoPreshape"]["detail"] and "cannot build me" in rows["FactoryRaises"]["detail"]
    assert rows["random"]["status"] not in ("planner_error", "harness_fault")
    again = run_benchmark(parse_config(data), tmp_path / "run", jobs=2, progress=False)
    assert again.ran == 0 and again.already_done == len(FAULTY) + 2


@pytest.mark.slow
@pytest.mark.parametrize("jobs", [1, 2])
def test_a_planner_that_sleeps_forever_is_a_timeout_for_its_group(tmp_path, jobs):
    data = dict(ONE, grasps_per_object=2, planners=["faulty_planners:Sleeps", "random"], trial_timeout_s=3)
    start = time.monotonic()
    run_benchmark(parse_config(data), tmp_path / "run", jobs=jobs, progress=False)
    rows = _rows(tmp_path / "run")
    assert len(rows) == 4 and time.monotonic() - start < 60
    assert {r["status"] for r in rows if r["planner"] == "Sleeps"} == {"timeout"}
    assert all("3 s budget" in r["detail"] for r in rows if r["planner"] == "Sleeps")
    assert {r["status"] for r in rows if r["planner"] == "random"} <= {s.value for s in Status} - {"timeout"}


@pytest.mark.slow
def test_a_trial_that_never_ends_is_a_timeout(tmp_path):
    data = dict(ONE, protocol="faulty_planners:sleeping_protocol", trial_timeout_s=1)
    run_benchmark(parse_config(data), tmp_path / "run", progress=False)
    (row,) = _rows(tmp_path / "run")
    assert row["status"] == "timeout" and "budget" in row["detail"]


def _children(pid: int) -> list[int]:
    import psutil

    try:
        return [c.pid for c in psutil.Process(pid).children(recursive=True)]
    except psutil.NoSuchProcess:
        return []


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL])
def test_workers_end_with_the_main_process(tmp_path, sig):
    import psutil

    config = tmp_path / "c.yaml"
    config.write_text("objects: [004_sugar_box]\nplanners: ['faulty_planners:Sleeps']\ngrasps_per_object: 1\n"
                      "trial_timeout_s: 600\n")
    cmd = [sys.executable, "-m", "manigrasp", "bench", str(config), "--out", str(tmp_path / "run"), "--quiet",
           "--jobs", "2"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and not _children(proc.pid):
        time.sleep(0.2)
    time.sleep(3.0)  # the worker has started and runs the sleeping planner
    workers = _children(proc.pid)
    assert workers
    os.kill(proc.pid, sig)
    proc.wait()
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline and any(psutil.pid_exists(p) and psutil.Process(p).status() != "zombie"
                                              for p in workers):
        time.sleep(0.2)
    alive = [p for p in workers if psutil.pid_exists(p) and psutil.Process(p).status() != "zombie"]
    assert not alive


@pytest.mark.slow
def test_ray_records_a_planner_that_crashes_its_worker_and_one_that_hangs(tmp_path):
    ray = pytest.importorskip("ray")
    data = dict(ONE, planners=["faulty_planners:Segfaults", "faulty_planners:Sleeps", "random"], trial_timeout_s=3)
    start = time.monotonic()
    try:
        summary = run_benchmark(parse_config(data), tmp_path / "run", jobs=2, executor="ray", progress=False)
    finally:
        ray.shutdown()
    rows = {r["planner"]: r for r in _rows(tmp_path / "run")}
    assert summary.ran == len(rows) == 3 and time.monotonic() - start < 120
    assert rows["Segfaults"]["status"] == "planner_error" and "Ray task failed" in rows["Segfaults"]["detail"]
    assert rows["Sleeps"]["status"] == "timeout" and "3 s budget" in rows["Sleeps"]["detail"]
    assert rows["random"]["status"] not in ("planner_error", "harness_fault", "timeout")


def test_an_edited_grasp_file_is_refused_on_resume(tmp_path):
    """A `file` planner's grasps edited between two sessions of one run mixed old and new grasps in one group (the
    file was not part of the run's identity); a run.json recorded before it was resumes as before."""
    import json

    from manigrasp.bench.rundir import check, prepare

    grasps = tmp_path / "grasps.json"
    grasps.write_text('{"grasps": 1}')
    config = parse_config(dict(ONE, planners=[{"name": "file", "params": {"path": str(grasps)}}, "random"]))
    meta = prepare(tmp_path / "run", config)
    assert set(meta["identity"]["grasp_file_sha256"]) == {"file"}
    assert check(tmp_path / "run", config) is not None  # unchanged: resumes
    grasps.write_text('{"grasps": 2}')
    with pytest.raises(ConfigError, match="grasp file of planner 'file' changed since this run started"):
        check(tmp_path / "run", config)
    old = json.loads((tmp_path / "run" / "run.json").read_text())
    del old["identity"]["grasp_file_sha256"]
    (tmp_path / "run" / "run.json").write_text(json.dumps(old))
    assert check(tmp_path / "run", config) is not None
    plain = parse_config(ONE)
    assert "grasp_file_sha256" not in prepare(tmp_path / "other", plain)["identity"]


@pytest.mark.slow
def test_a_planning_worker_killed_from_outside_is_a_harness_fault_that_a_resume_retries(tmp_path):
    """SIGKILL (the OOM killer, a person) while planning filed the group as the planner's error, counted against it
    and never run again; a segfault stays the planner's (`test_crashing_and_malformed_planners...`)."""
    data = dict(ONE, planners=["faulty_planners:KilledFromOutside"])
    first = run_benchmark(parse_config(data), tmp_path / "run", jobs=1, progress=False)
    rows = _rows(tmp_path / "run")
    assert first.ran == len(rows) > 0
    assert all(r["status"] == "harness_fault" and "SIGKILL" in r["detail"] for r in rows), rows[0]
    again = run_benchmark(parse_config(data), tmp_path / "run", jobs=1, progress=False)
    assert again.ran == first.ran and again.already_done == 0 and len(_rows(tmp_path / "run")) == len(rows)
