"""Exports of a run's results table (CSV, Parquet)."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

from manigrasp.bench.store import KEY_COLUMNS


def export(rows: Iterable[dict[str, object]], path: Path) -> Path:
    """Write rows to ``.csv`` or ``.parquet`` (by the suffix of `path`)."""
    rows = list(rows)
    path = Path(path)
    if path.suffix == ".parquet":
        import pyarrow as pa
        import pyarrow.parquet as pq

        pq.write_table(pa.Table.from_pylist(rows), path)
    elif path.suffix == ".csv":
        import csv

        with path.open("w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=list(rows[0]) if rows else list(KEY_COLUMNS))
            writer.writeheader()
            writer.writerows(rows)
    else:
        raise ValueError(f"unknown export format {path.suffix!r}: use .csv or .parquet")
    return path
