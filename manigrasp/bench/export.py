"""Exports of a run's results table (CSV, Parquet): one row per trial, for pandas, R or a spreadsheet.

Columns: the trial's key (`trial_id`, `object`, `hand`, `planner` (the planner's label in tables),
`observation`, `protocol`, `grasp_index`), a boolean `success` beside `status`, then every stored
measurement with its unit in its name (``_m``, ``_deg``, ``_n``, ``_s``, ``_mm``): the executed grasp's TCP
pose in the world (`grasp_x_m`, `grasp_y_m`, `grasp_z_m`, `grasp_qw`..`grasp_qz`: position and unit
quaternion w, x, y, z), its jaw opening `grasp_width_m` and pre-shape `grasp_preshape` (0..1), the settled
object pose (`object_*`, same layout), the analytic metrics of the planned (`planned_*`) and simulated
(`sim_*`) contacts with force closure as a boolean, an estimated pose's errors (`pose_*`; `pose_symmetric`, a
boolean: whether its object has a symmetry, so its pose is judged by ADD-S), timings (`plan_time_s`: the whole
planning call, `planning_time_s`: that per candidate). A value that was not computed is empty in CSV and null in
Parquet.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Iterable
from pathlib import Path

from manigrasp.bench.store import KEY_COLUMNS
from manigrasp.errors import ConfigError
from manigrasp.protocol.result import Status, TrialResult

FORMATS = ("csv", "parquet")
BOOLEAN_COLUMNS = ("success", "planned_force_closure", "sim_force_closure", "pose_symmetric")
PARQUET_INSTALL = "install the parquet extra from the clone: make setup EXTRAS=dev,parquet"


def _types() -> dict[str, type]:
    """Python type of every exported column, in export order."""
    sample = TrialResult(status=Status.SUCCESS).flat()
    out: dict[str, type] = {name: str for name in KEY_COLUMNS}
    out["grasp_index"] = int
    out["success"] = bool
    out.update({name: type(value) for name, value in sample.items()})
    out.update(dict.fromkeys(BOOLEAN_COLUMNS, bool))
    return out


COLUMNS: dict[str, type] = _types()


def export_row(row: dict[str, object]) -> dict[str, object]:
    """One store row (`ResultsStore.rows`) as an export row: `success` added, `BOOLEAN_COLUMNS` boolean, NaN None."""
    out: dict[str, object] = {}
    for name, kind in COLUMNS.items():
        value = row.get("status") == Status.SUCCESS.value if name == "success" else row.get(name)
        if isinstance(value, float) and math.isnan(value):
            value = None
        elif value is not None and kind is bool:
            value = bool(value)
        out[name] = value
    return out


def export(rows: Iterable[dict[str, object]], path: Path) -> Path:
    """Write store rows to ``.csv`` or ``.parquet`` (by the suffix of `path`); returns `path`.

    Raises `ConfigError` for another suffix, or for Parquet without pyarrow (the `parquet` extra).
    """
    path = Path(path)
    kind = path.suffix.lstrip(".")
    if kind not in FORMATS:
        raise ConfigError(f"unknown export format {path.suffix!r} ({path}): use .csv or .parquet")
    table = [export_row(r) for r in rows]
    if kind == "parquet":
        _write_parquet(table, path)
    else:
        with path.open("w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=list(COLUMNS))
            writer.writeheader()
            writer.writerows(table)
    return path


def _write_parquet(table: list[dict[str, object]], path: Path) -> None:
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError as exc:
        raise ConfigError(f"Parquet export needs pyarrow, which is not installed: {PARQUET_INSTALL}; "
                          "or use --format csv") from exc
    arrow = {bool: pa.bool_(), int: pa.int64(), float: pa.float64(), str: pa.string()}
    schema = pa.schema([(name, arrow[kind]) for name, kind in COLUMNS.items()])
    pq.write_table(pa.Table.from_pylist(table, schema=schema), path)
