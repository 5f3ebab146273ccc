"""Results store: round trip, no duplicates, resume after a kill -9."""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from manigrasp.bench.store import ResultsStore, TrialKey
from manigrasp.errors import ConfigError
from manigrasp.protocol.result import GraspMetrics, PoseRecord, Status, TrialResult


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


def test_grasp_and_object_poses_round_trip_through_the_store(tmp_path):
    """The executed grasp and the settled object pose are stored, so a trial can be re-placed later."""
    rng = np.random.default_rng(4)
    grasp, obj = np.eye(4), np.eye(4)
    grasp[:3, :3], grasp[:3, 3] = Rotation.random(random_state=rng).as_matrix(), [0.1, -0.2, 0.3]
    obj[:3, :3], obj[:3, 3] = Rotation.random(random_state=rng).as_matrix(), [0.0, 0.01, 0.05]
    result = TrialResult(Status.SUCCESS, grasp=PoseRecord.of(grasp), grasp_width_m=0.05, grasp_preshape=0.0,
                         object_pose=PoseRecord.of(obj), plan_time_s=0.8)
    with ResultsStore(tmp_path / "results.sqlite") as store:
        store.add(_key(0), result)
        (_, back), = list(store.results())
    assert back == result
    np.testing.assert_allclose(back.grasp.matrix(), grasp, atol=1e-12)
    np.testing.assert_allclose(back.object_pose.matrix(), obj, atol=1e-12)
    assert back.grasp.qw >= 0
    assert math.isnan(PoseRecord.of(np.full((4, 4), np.nan)).x_m)


def test_a_store_written_before_the_pose_columns_is_extended_not_lost(tmp_path):
    """Resuming a run stored by an older version adds the new columns; old rows read as NaN there."""
    import sqlite3

    path = tmp_path / "results.sqlite"
    with ResultsStore(path) as store:
        store.add(_key(0), _result(0))
    db = sqlite3.connect(path)
    db.execute("ALTER TABLE trials DROP COLUMN plan_time_s")
    db.execute("ALTER TABLE trials DROP COLUMN grasp_qw")
    db.execute("ALTER TABLE trials DROP COLUMN camera_views")  # an int column: NULL read as NaN crashed report
    db.commit()
    db.close()
    with ResultsStore(path) as store:
        assert store.add(_key(1), _result(1))
        rows = dict(store.results())
    assert rows[_key(1)] == _result(1)
    assert math.isnan(rows[_key(0)].plan_time_s) and math.isnan(rows[_key(0)].grasp.qw)
    assert rows[_key(0)].status is Status.SUCCESS and rows[_key(0)].camera_views == 0
    from manigrasp.bench.report import summarize

    assert summarize(list(rows.items())).views  # (int(NaN or 0) raised ValueError)


def test_a_trial_is_never_stored_twice(tmp_path):
    with ResultsStore(tmp_path / "results.sqlite") as store:
        assert store.add(_key(3), _result(3))
        assert not store.add(_key(3), _result(4))
        assert store.count() == 1 and next(store.results())[1].seed == 3


def test_trial_id_is_readable_and_unique():
    assert _key(7).trial_id == "025_mug/parallel_jaw/antipodal/ground_truth/standard/0007"
    assert len({_key(i).trial_id for i in range(100)}) == 100


@pytest.mark.slow
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


def test_a_read_only_open_writes_nothing_and_refuses_writes(tmp_path):
    """Opening read-only creates no file where there is none, and cannot add a trial."""
    import sqlite3

    missing = tmp_path / "none" / "results.sqlite"
    with pytest.raises(ConfigError, match="no results store"):
        ResultsStore(missing, readonly=True)
    assert not missing.parent.exists()
    with ResultsStore(tmp_path / "results.sqlite") as store:
        store.add(_key(0), _result(0))
    with ResultsStore(tmp_path / "results.sqlite", readonly=True) as store:
        assert [k for k, _ in store.results()] == [_key(0)]
        with pytest.raises(sqlite3.OperationalError, match="readonly"):
            store.add(_key(1), _result(1))


def test_a_garbage_store_or_a_bad_row_is_a_config_error(tmp_path):
    import sqlite3

    garbage = tmp_path / "garbage.sqlite"
    garbage.write_bytes(b"\x00garbage" * 500)
    with pytest.raises(ConfigError, match="not a readable manigrasp results store"):
        ResultsStore(garbage, readonly=True)
    path = tmp_path / "results.sqlite"
    with ResultsStore(path) as store:
        store.add(_key(0), _result(0))
    db = sqlite3.connect(path)
    db.execute("UPDATE trials SET status = 'exploded'")
    db.commit()
    db.close()
    with ResultsStore(path, readonly=True) as store, pytest.raises(ConfigError, match="not a valid row"):
        list(store.results())


def test_a_store_written_before_perturb_direction_reads_back_as_it_was_written(tmp_path):
    """An older store has no perturb_direction column: its rows read back with the direction their detail
    began with (as the report parsed it then), and its last_phase strings as the same `Phase` values."""
    import sqlite3

    from manigrasp.protocol.result import Phase

    path = tmp_path / "results.sqlite"
    dropped = TrialResult(Status.DROPPED_PERTURB, detail="-y: object moved 2.5 cm / 3.0 deg in the hand",
                          last_phase="lift", perturb_direction="-y")
    shaken = TrialResult(Status.DROPPED_PERTURB, detail="shake: object moved 4.1 cm / 0.0 deg in the hand",
                         last_phase="lift")
    with ResultsStore(path) as store:
        for i, result in enumerate((dropped, shaken, _result(2))):
            store.add(_key(i), result)
    with sqlite3.connect(path) as db:
        db.execute("ALTER TABLE trials DROP COLUMN perturb_direction")
    with ResultsStore(path, readonly=True) as old:
        again = [r for _, r in old.results()]
    assert again[0] == dropped and again[0].perturb_direction == "-y"
    assert again[1] == shaken and again[1].perturb_direction == ""
    assert all(r.last_phase is Phase.LIFT for r in again)
    with ResultsStore(path) as reopened:  # opened for writing: the column is added, NULL for the old rows
        assert [r for _, r in reopened.results()] == again
