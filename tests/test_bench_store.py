"""Results store: round trip, no duplicates, resume after a kill -9."""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import textwrap

import pytest

from manigrasp.bench.export import export
from manigrasp.bench.store import ResultsStore, TrialKey
from manigrasp.protocol.result import GraspMetrics, Status, TrialResult


def _result(i: int) -> TrialResult:
    return TrialResult(
        status=Status.DROPPED_PERTURB if i % 2 else Status.SUCCESS, detail="-z" if i % 2 else "",
        last_phase="lift", max_translation_m=0.001 * i, max_rotation_deg=1.5, fingers_in_contact=("left", "right"),
        grip_force_n=20.0, planned=GraspMetrics(2, 1.0, 0.12, 0.3), simulated=GraspMetrics(4, 0.0, 0.0, math.inf),
        planning_time_s=0.01, sim_steps=1000 + i, sim_time_s=2.0, wall_time_s=0.5, seed=i)


def _key(i: int) -> TrialKey:
    return TrialKey("025_mug", "parallel_jaw", "antipodal", "ground_truth", "standard", i)


def test_round_trip_keeps_every_field_including_nan_and_inf(tmp_path):
    with ResultsStore(tmp_path / "results.sqlite") as store:
        original = TrialResult(status=Status.PLANNER_ERROR, detail="boom")  # NaN metrics, no fingers
        assert store.add(_key(0), original) and store.add(_key(1), _result(1))
        (k0, r0), (k1, r1) = list(store.results())
    assert k0 == _key(0) and k1 == _key(1)
    assert r1 == _result(1) and r1.simulated.min_friction == math.inf
    assert r0.status is Status.PLANNER_ERROR and r0.detail == "boom" and math.isnan(r0.planned.epsilon_l1)
    assert r0.fingers_in_contact == ()


def test_a_trial_is_never_stored_twice(tmp_path):
    with ResultsStore(tmp_path / "results.sqlite") as store:
        assert store.add(_key(3), _result(3))
        assert not store.add(_key(3), _result(4))
        assert store.count() == 1 and next(store.results())[1].seed == 3


def test_trial_id_is_readable_and_unique():
    assert _key(7).trial_id == "025_mug/parallel_jaw/antipodal/ground_truth/standard/0007"
    assert len({_key(i).trial_id for i in range(100)}) == 100


def test_kill_9_loses_nothing_committed_and_resume_completes_the_set(tmp_path):
    """A writer killed mid-run leaves only whole rows; a second writer adds the rest, none twice."""
    db = tmp_path / "results.sqlite"
    script = textwrap.dedent(f"""
        import sys, time
        sys.path.insert(0, {str(os.path.dirname(__file__))!r})
        from test_bench_store import _key, _result
        from manigrasp.bench.store import ResultsStore
        store = ResultsStore({str(db)!r})
        done = store.done_ids()
        for i in range(200):
            if _key(i).trial_id in done:
                continue
            store.add(_key(i), _result(i))
            print(i, flush=True)
            time.sleep(0.01)
    """)
    proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    for _ in range(30):
        proc.stdout.readline()
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    with ResultsStore(db) as store:
        partial = store.count()
    assert 30 <= partial < 200
    subprocess.run([sys.executable, "-c", script], check=True, capture_output=True, timeout=120)
    with ResultsStore(db) as store:
        assert store.count() == 200
        assert sorted(k.grasp_index for k, _ in store.results()) == list(range(200))


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_export(tmp_path, suffix):
    with ResultsStore(tmp_path / "results.sqlite") as store:
        for i in range(3):
            store.add(_key(i), _result(i))
        path = export(store.rows(), tmp_path / f"results{suffix}")
    assert path.stat().st_size > 0
    if suffix == ".parquet":
        import pyarrow.parquet as pq

        table = pq.read_table(path)
        assert table.num_rows == 3 and "sim_epsilon_l1" in table.column_names
    else:
        assert path.read_text().count("\n") == 4

