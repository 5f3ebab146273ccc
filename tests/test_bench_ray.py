"""The Ray executor (`manigrasp.bench.pool.RayPool`, `run_benchmark(executor="ray")`) on a local Ray instance: the
same trial results as the local pool, and an interrupted run resumed on Ray loses no trial and counts none twice.
Skipped without the optional `ray` extra."""

from __future__ import annotations

from pathlib import Path

import pytest

from manigrasp.bench.config import parse_config
from manigrasp.bench.runner import run_benchmark
from manigrasp.bench.store import ResultsStore

ray = pytest.importorskip("ray")

pytestmark = pytest.mark.slow  # a Ray instance starts in ~5 s; each test runs a few trials twice (~20-40 s)

# test_bench_e2e's SMALL, one planner: 2 objects x 3 grasps, plans and trials as separate Ray tasks.
SMALL = {"name": "small", "objects": ["004_sugar_box", "005_tomato_soup_can"], "planners": ["antipodal"],
         "grasps_per_object": 3, "protocol": "lift"}
TIMING = {"wall_time_s", "planning_time_s", "plan_time_s"}  # the only columns that differ between two runs


@pytest.fixture(scope="module")
def local_ray():
    """A local Ray instance of 2 CPUs for the module (`run_benchmark` uses the initialised one), shut down after."""
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        yield ray
    finally:
        ray.shutdown()


@pytest.fixture(scope="module")
def local_rows(tmp_path_factory) -> list[dict]:
    """SMALL's rows from the local pool, the reference."""
    run_dir = tmp_path_factory.mktemp("local") / "run"
    summary = run_benchmark(parse_config(SMALL), run_dir, jobs=2, progress=False)
    assert summary.ran == 6
    return _rows(run_dir)


def _rows(run_dir: Path) -> list[dict]:
    """The run's stored trials without their timings, by trial id."""
    with ResultsStore(run_dir / "results.sqlite") as store:
        return [{k: v for k, v in row.items() if k not in TIMING} for row in store.rows()]


def test_ray_executor_stores_the_local_pools_results(local_ray, local_rows, tmp_path):
    seen = []
    summary = run_benchmark(parse_config(SMALL), tmp_path / "run", jobs=2, executor="ray", progress=False,
                            on_result=lambda key, result: seen.append(key.trial_id))
    assert (summary.total, summary.already_done, summary.ran) == (6, 0, 6)
    rows = _rows(tmp_path / "run")
    assert sorted(seen) == [r["trial_id"] for r in rows]  # every trial reported once
    assert rows == local_rows, [(r["trial_id"], r["status"], r["detail"]) for r in rows]
    assert local_ray.is_initialized()  # the run used the instance it found, and left it up


def test_an_interrupted_ray_run_resumes_losing_and_repeating_nothing(local_ray, local_rows, tmp_path):
    """A Ctrl-C in the driver after 2 stored trials (the other tasks still running on Ray are cancelled, their
    results never stored); the resumed run on Ray runs only the other 4, and the store holds each trial once with
    the local pool's result."""
    stored = []

    def interrupt_after_two(key, result) -> None:
        stored.append(key.trial_id)
        if len(stored) == 2:
            raise KeyboardInterrupt

    config, run_dir = parse_config(SMALL), tmp_path / "run"
    with pytest.raises(KeyboardInterrupt):
        run_benchmark(config, run_dir, jobs=2, executor="ray", progress=False, on_result=interrupt_after_two)
    assert [r["trial_id"] for r in _rows(run_dir)] == sorted(stored)  # only the trials reported before the Ctrl-C
    again = []
    summary = run_benchmark(config, run_dir, jobs=2, executor="ray", progress=False,
                            on_result=lambda key, result: again.append(key.trial_id))
    assert (summary.total, summary.already_done, summary.ran) == (6, 2, 4)
    assert sorted(again) == sorted({r["trial_id"] for r in local_rows} - set(stored))  # the rest, each once
    assert _rows(run_dir) == local_rows
