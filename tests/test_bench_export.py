"""Exports: one row per trial that pandas/R read as typed columns, units in names, `manigrasp export`."""

from __future__ import annotations

import csv
import json
import math
import sys

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from test_bench_report import RUN_META, make_run

from manigrasp.bench.export import COLUMNS, export
from manigrasp.bench.store import ResultsStore, TrialKey
from manigrasp.cli import main
from manigrasp.errors import ConfigError
from manigrasp.protocol.result import GraspMetrics, PoseRecord, Status, TrialResult

# Columns that are counts, labels, or dimensionless by nature (everything else names its unit).
UNITLESS = {"trial_id", "object", "hand", "planner", "observation", "protocol", "grasp_index", "success", "status",
            "detail", "last_phase", "fingers_in_contact", "score", "sim_steps", "seed", "grasp_preshape",
            "rest_index", "rest_probability", "pose_symmetric",
            *(f"{p}_{q}" for p in ("grasp", "object", "rest") for q in ("qw", "qx", "qy", "qz")),
            *(f"{p}_{m}" for p in ("planned", "sim")
              for m in ("n_contacts", "force_closure", "epsilon_l1", "min_friction"))}
UNITS = ("_m", "_deg", "_n", "_s", "_mm")


def _trials() -> list[tuple[TrialKey, TrialResult]]:
    pose = np.eye(4)
    pose[:3, :3] = Rotation.from_euler("x", 180, degrees=True).as_matrix()  # approach straight down
    pose[:3, 3] = [0.01, -0.02, 0.15]
    ok = TrialResult(Status.SUCCESS, planned=GraspMetrics(2, 1.0, 0.12, 0.3), simulated=GraspMetrics(8, 1.0, 0.08, 0.2),
                     grasp=PoseRecord.of(pose), grasp_width_m=0.055, grasp_preshape=0.0, plan_time_s=0.9,
                     planning_time_s=0.045)
    failed = TrialResult(Status.NO_CONTACT, planned=GraspMetrics(2, 0.0, 0.0, math.inf), grasp=PoseRecord.of(pose),
                         grasp_width_m=0.07)  # simulated metrics not computed: NaN
    return [(TrialKey("025_mug", "parallel_jaw", "antipodal (lift=0.04)", "ground_truth", "standard", i), r)
            for i, r in enumerate((ok, failed))]


@pytest.fixture
def rows(tmp_path):
    with ResultsStore(tmp_path / "store.sqlite") as store:
        for key, result in _trials():
            store.add(key, result)
        return list(store.rows())


def test_every_measured_column_names_its_unit():
    for name, kind in COLUMNS.items():
        if kind is float and name not in UNITLESS:
            assert name.endswith(UNITS), f"{name} has no unit in its name"
    assert {"success", "grasp_x_m", "grasp_qw", "grasp_qz", "grasp_width_m", "grasp_preshape", "plan_time_s"} \
        <= set(COLUMNS)


def test_parquet_columns_are_typed_booleans_and_nulls(tmp_path, rows):
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pq.read_table(export(rows, tmp_path / "results.parquet"))
    assert table.schema.field("success").type == pa.bool_()
    assert table.schema.field("planned_force_closure").type == pa.bool_()
    assert table.schema.field("sim_force_closure").type == pa.bool_()
    assert table.schema.field("sim_epsilon_l1").type == pa.float64()  # not the null type, though NaN on a row
    data = table.to_pydict()
    assert data["success"] == [True, False] and data["planned_force_closure"] == [True, False]
    assert data["sim_force_closure"] == [True, None] and data["sim_epsilon_l1"][1] is None
    assert data["planner"] == ["antipodal (lift=0.04)"] * 2
    assert data["grasp_z_m"] == [0.15, 0.15] and data["grasp_qw"][0] == pytest.approx(0.0, abs=1e-12)
    assert data["grasp_qx"][0] == pytest.approx(1.0) and data["grasp_width_m"] == [0.055, 0.07]
    assert data["planned_min_friction"][1] == math.inf


def test_csv_has_a_boolean_success_and_empty_cells_for_not_computed(tmp_path, rows):
    with export(rows, tmp_path / "results.csv").open() as f:
        table = list(csv.DictReader(f))
    assert [r["success"] for r in table] == ["True", "False"]
    assert [r["sim_force_closure"] for r in table] == ["True", ""]
    assert table[0]["grasp_width_m"] == "0.055" and table[0]["status"] == "success"
    assert list(table[0]) == list(COLUMNS)


def test_parquet_without_pyarrow_says_which_extra_to_install(tmp_path, rows, monkeypatch):
    monkeypatch.setitem(sys.modules, "pyarrow", None)
    monkeypatch.setitem(sys.modules, "pyarrow.parquet", None)
    with pytest.raises(ConfigError, match="pyarrow.*EXTRAS=dev,parquet"):
        export(rows, tmp_path / "results.parquet")
    assert not (tmp_path / "results.parquet").exists()


def test_unknown_suffix_is_a_config_error(tmp_path, rows):
    with pytest.raises(ConfigError, match="use .csv or .parquet"):
        export(rows, tmp_path / "results.xlsx")


@pytest.mark.parametrize("fmt", ["csv", "parquet"])
def test_export_command_writes_the_run_table_without_the_config(tmp_path, capsys, fmt):
    run = make_run(tmp_path / "run", _trials(), RUN_META)
    assert main(["export", str(run), "--format", fmt]) == 0
    path = run / f"results.{fmt}"
    assert f"exported {path}" in capsys.readouterr().out
    if fmt == "parquet":
        import pyarrow.parquet as pq

        assert pq.read_table(path).num_rows == 2
    else:
        assert path.read_text().count("\n") == 3


def test_export_command_errors_are_one_line(tmp_path, capsys):
    run = tmp_path / "run"
    run.mkdir()
    (run / "run.json").write_text(json.dumps(RUN_META))
    assert main(["export", str(run)]) == 2
    assert "holds no results.sqlite" in capsys.readouterr().err
    assert sorted(p.name for p in run.iterdir()) == ["run.json"]
    run = make_run(tmp_path / "run2", _trials(), RUN_META)
    assert main(["export", str(run), "--out", str(tmp_path / "x.parquet")]) == 2
    assert main(["export", str(run), "--out", str(tmp_path / "missing" / "x.csv")]) == 2
    assert "not a writable folder" in capsys.readouterr().err


def test_the_parquet_extra_is_declared_pinned_as_locked_and_installed_by_ci():
    import tomllib
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    extras = tomllib.loads((root / "pyproject.toml").read_text())["project"]["optional-dependencies"]
    locked = [line for line in (root / "constraints.txt").read_text().splitlines() if line.startswith("pyarrow==")]
    assert extras["parquet"] == locked
    ci = next(line for line in (root / ".ci" / "run").read_text().splitlines() if line.startswith("EXTRAS="))
    assert "parquet" in ci.split("=", 1)[1].split(",")
