"""The harness end to end on small configs: counts, resume after kill -9, reproducibility, faults."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from manigrasp.bench.config import parse_config
from manigrasp.bench.runner import run_benchmark
from manigrasp.bench.store import ResultsStore
from manigrasp.cli import main
from manigrasp.errors import ConfigError, UnknownNameError
from manigrasp.protocol.result import Status

TESTS = Path(__file__).parent
SMALL = {"name": "small", "objects": ["004_sugar_box", "005_tomato_soup_can"], "planners": ["antipodal", "random"],
         "grasps_per_object": 3, "protocol": "lift"}


@pytest.fixture(autouse=True)
def _user_modules_importable(monkeypatch):
    monkeypatch.syspath_prepend(str(TESTS))


def _rows(run_dir: Path) -> list[dict]:
    with ResultsStore(run_dir / "results.sqlite") as store:
        return list(store.rows())


@pytest.mark.slow
def test_every_trial_is_stored_once_with_its_status(tmp_path):
    summary = run_benchmark(parse_config(SMALL), tmp_path / "run", progress=False)
    rows = _rows(tmp_path / "run")
    assert summary.total == summary.ran == len(rows) == 2 * 2 * 3
    assert {r["status"] for r in rows} <= {s.value for s in Status}
    antipodal = [r for r in rows if r["planner"] == "antipodal"]
    assert sum(r["status"] == "success" for r in antipodal) >= 5  # boxes and cans are easy for antipodal
    for r in antipodal:  # each row carries the grasp it executed and the object pose it was planned on
        grasp = np.array([r[f"grasp_{k}"] for k in ("x_m", "y_m", "z_m", "qw", "qx", "qy", "qz")])
        obj = np.array([r[f"object_{k}"] for k in ("x_m", "y_m", "z_m", "qw", "qx", "qy", "qz")])
        assert np.all(np.isfinite(grasp)) and np.all(np.isfinite(obj))
        assert abs(np.linalg.norm(grasp[3:]) - 1) < 1e-9 and np.linalg.norm(grasp[:3] - obj[:3]) < 0.15
        assert 0 < r["grasp_width_m"] <= 0.08 and r["plan_time_s"] >= r["planning_time_s"] > 0
    again = run_benchmark(parse_config(SMALL), tmp_path / "run", progress=False)
    assert again.ran == 0 and again.already_done == 12 and len(_rows(tmp_path / "run")) == 12


@pytest.mark.slow
def test_same_config_and_seed_give_identical_rows(tmp_path):
    run_benchmark(parse_config(SMALL), tmp_path / "a", progress=False)
    run_benchmark(parse_config(SMALL), tmp_path / "b", progress=False, in_process=True)  # same rows either way
    timing = {"wall_time_s", "planning_time_s", "plan_time_s"}
    strip = [{k: v for k, v in r.items() if k not in timing} for r in _rows(tmp_path / "a")]
    assert strip == [{k: v for k, v in r.items() if k not in timing} for r in _rows(tmp_path / "b")]
    other = run_benchmark(parse_config(SMALL, ["seed=1"]), tmp_path / "c", progress=False)
    assert other.ran == 12
    seeds_a = {r["seed"] for r in _rows(tmp_path / "a")}
    assert seeds_a.isdisjoint({r["seed"] for r in _rows(tmp_path / "c")})


@pytest.mark.slow
def test_kill_9_then_resume_loses_and_duplicates_nothing(tmp_path):
    config = tmp_path / "c.yaml"
    config.write_text("objects: [004_sugar_box, 005_tomato_soup_can]\nplanners: [antipodal]\n"
                      "grasps_per_object: 6\nprotocol: lift\n")
    run_dir = tmp_path / "run"
    cmd = [sys.executable, "-m", "manigrasp", "bench", str(config), "--out", str(run_dir), "--quiet"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 240
    while time.monotonic() < deadline:
        assert proc.poll() is None, proc.stderr.read().decode()[-2000:]
        if (run_dir / "results.sqlite").exists() and 2 <= len(_rows(run_dir)):
            break
        time.sleep(0.2)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    partial = len(_rows(run_dir))
    assert 2 <= partial < 12, partial
    assert main(["bench", str(config), "--out", str(run_dir), "--quiet"]) == 0
    rows = _rows(run_dir)
    assert len(rows) == 12 and len({r["trial_id"] for r in rows}) == 12


@pytest.mark.slow
def test_a_planner_that_raises_or_returns_nan_is_a_recorded_status(tmp_path):
    data = dict(SMALL, objects=["004_sugar_box"], planners=["faulty_planners:Raises", "faulty_planners:ReturnsNaN"])
    run_benchmark(parse_config(data), tmp_path / "run", progress=False)
    rows = _rows(tmp_path / "run")
    assert len(rows) == 6 and {r["status"] for r in rows} == {"planner_error"}
    raised = [r for r in rows if r["planner"] == "Raises"]
    assert all("planner exploded" in r["detail"] for r in raised)
    nan = [r for r in rows if r["planner"] == "ReturnsNaN"]
    assert all("NaN" in r["detail"] for r in nan)


@pytest.mark.parametrize(("change", "error"), [
    ({"hands": ["no_such_hand"]}, UnknownNameError),
    ({"planners": ["no_such_planner"]}, UnknownNameError),
    ({"objects": ["no_such_object"]}, UnknownNameError),
    ({"protocol": "no_such_protocol"}, UnknownNameError),
    ({"protocol": {"name": "lift", "params": {"hold_secs": 1}}}, ConfigError),
])
def test_bad_names_fail_before_any_trial(tmp_path, change, error):
    with pytest.raises(error):
        run_benchmark(parse_config(dict(SMALL, **change)), tmp_path / "run", progress=False)
    assert not (tmp_path / "run" / "results.sqlite").exists()


@pytest.mark.slow
def test_a_different_config_is_not_mixed_into_an_existing_run(tmp_path):
    small = dict(SMALL, objects=["004_sugar_box"], planners=["random"], grasps_per_object=1)
    run_benchmark(parse_config(small), tmp_path / "run", progress=False)
    with pytest.raises(ConfigError, match="different config"):
        run_benchmark(parse_config(small, ["seed=5"]), tmp_path / "run", progress=False)


@pytest.mark.slow
def test_two_workers_give_the_same_rows_as_one(tmp_path):
    one = run_benchmark(parse_config(SMALL), tmp_path / "one", progress=False)
    two = run_benchmark(parse_config(SMALL), tmp_path / "two", jobs=2, progress=False)
    assert one.ran == two.ran == 12
    timing = {"wall_time_s", "planning_time_s", "plan_time_s"}
    assert ([{k: v for k, v in r.items() if k not in timing} for r in _rows(tmp_path / "one")]
            == [{k: v for k, v in r.items() if k not in timing} for r in _rows(tmp_path / "two")])


@pytest.mark.slow
def test_ray_executor_runs_the_same_trials(tmp_path):
    ray = pytest.importorskip("ray")
    small = dict(SMALL, objects=["004_sugar_box"], planners=["antipodal"])
    try:
        summary = run_benchmark(parse_config(small), tmp_path / "ray", jobs=2, executor="ray", progress=False)
    finally:
        ray.shutdown()
    local = run_benchmark(parse_config(small), tmp_path / "local", progress=False)
    assert summary.ran == local.ran == 3
    ray_rows = _rows(tmp_path / "ray")
    assert [r["status"] for r in ray_rows] == [r["status"] for r in _rows(tmp_path / "local")], [
        r["detail"] for r in ray_rows]


@pytest.mark.slow
def test_recording_keeps_the_chosen_trials_and_changes_no_result(tmp_path):
    small = dict(SMALL, objects=["004_sugar_box"], planners=["random"], grasps_per_object=4)
    run_benchmark(parse_config(small), tmp_path / "plain", progress=False)
    run_benchmark(parse_config(small), tmp_path / "rec", progress=False, record="failures")
    timing = {"wall_time_s", "planning_time_s", "plan_time_s"}
    plain, rec = _rows(tmp_path / "plain"), _rows(tmp_path / "rec")
    assert [{k: v for k, v in r.items() if k not in timing} for r in plain] == [
        {k: v for k, v in r.items() if k not in timing} for r in rec]
    failed = {r["trial_id"].replace("/", "__") + ".rrd" for r in rec if r["status"] != "success"}
    kept = {p.name for p in (tmp_path / "rec" / "recordings").glob("*.rrd")}
    assert failed and kept == failed
    assert not list((tmp_path / "rec" / "recordings").glob("*.partial"))
