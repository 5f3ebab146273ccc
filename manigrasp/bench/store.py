"""The resumable results store: one SQLite row per trial, committed as it finishes.

The primary key is the trial id, so a re-run that re-enumerates the same
trials skips the stored ones and can never count one twice; each row is its
own transaction, so a kill -9 loses at most the trial that was running.
"""

from __future__ import annotations

import json
import math
import os
import sqlite3
from collections.abc import Iterator
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

from manigrasp.errors import ConfigError
from manigrasp.protocol.result import Status, TrialResult

KEY_COLUMNS = ("trial_id", "object", "hand", "planner", "observation", "protocol", "grasp_index")


@dataclass(frozen=True)
class TrialKey:
    """Identity of one trial in a run."""

    object: str
    hand: str
    planner: str
    observation: str
    protocol: str
    grasp_index: int

    @property
    def trial_id(self) -> str:
        """A stable, readable id: ``object/hand/planner/observation/protocol/0007``."""
        return f"{self.object}/{self.hand}/{self.planner}/{self.observation}/{self.protocol}/{self.grasp_index:04d}"


def _result_columns() -> list[tuple[str, str]]:
    sample = TrialResult(status=Status.SUCCESS).flat()
    kinds = {bool: "INTEGER", int: "INTEGER", float: "REAL", str: "TEXT"}
    return [(name, kinds.get(type(value), "TEXT")) for name, value in sample.items()]


class ResultsStore:
    """`results.sqlite` of a run directory."""

    def __init__(self, path: Path, readonly: bool = False) -> None:
        """Open (and create, unless `readonly`) the store at `path`.

        Read-only opens an existing file without writing anything, also in a read-only directory;
        a file that is not a results store raises `ConfigError`.
        """
        self.path = Path(path)
        self.readonly = readonly
        self._columns = _result_columns()
        if readonly:
            self._db = _open_readonly(self.path)
            return
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._db = sqlite3.connect(self.path, timeout=60.0)
        self._db.execute("PRAGMA journal_mode=WAL")
        self._db.execute("PRAGMA synchronous=FULL")
        cols = ", ".join(f"{n} {t}" for n, t in self._columns)
        self._db.execute(
            "CREATE TABLE IF NOT EXISTS trials (trial_id TEXT PRIMARY KEY, object TEXT, hand TEXT, planner TEXT, "
            f"observation TEXT, protocol TEXT, grasp_index INTEGER, {cols})")
        # A store written by an older manigrasp lacks newer result columns: add them (NULL = not recorded).
        present = {row[1] for row in self._db.execute("PRAGMA table_info(trials)")}
        for name, kind in self._columns:
            if name not in present:
                self._db.execute(f"ALTER TABLE trials ADD COLUMN {name} {kind}")
        self._db.commit()

    def close(self) -> None:
        """Close the database."""
        self._db.close()

    def __enter__(self) -> ResultsStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def done_ids(self) -> set[str]:
        """Ids of the trials already stored."""
        return {row[0] for row in self._db.execute("SELECT trial_id FROM trials")}

    def fault_ids(self) -> set[str]:
        """Ids of the stored trials that ended as `harness_fault` (a resumed run runs them again)."""
        return {row[0] for row in self._db.execute("SELECT trial_id FROM trials WHERE status = ?",
                                                   (Status.HARNESS_FAULT.value,))}

    def add(self, key: TrialKey, result: TrialResult, replace_fault: bool = False) -> bool:
        """Store one trial (its own transaction); False if it was already stored. With `replace_fault`, a stored
        `harness_fault` of the same trial is replaced (its re-run), nothing else."""
        flat = result.flat()
        values = [key.trial_id, key.object, key.hand, key.planner, key.observation, key.protocol, key.grasp_index]
        values += [_sql_value(flat[name]) for name, _ in self._columns]
        marks = ", ".join("?" * len(values))
        with self._db:  # one transaction: a fault replaced is either still there or its re-run is
            if replace_fault:
                self._db.execute("DELETE FROM trials WHERE trial_id = ? AND status = ?",
                                 (key.trial_id, Status.HARNESS_FAULT.value))
            names = ", ".join(("trial_id", *KEY_COLUMNS[1:], *(n for n, _ in self._columns)))
            cursor = self._db.execute(f"INSERT OR IGNORE INTO trials ({names}) VALUES ({marks})", values)
        return cursor.rowcount == 1

    def rows(self) -> Iterator[dict[str, object]]:
        """Every stored trial as a flat dict (key columns + `TrialResult.flat()` columns)."""
        try:
            cursor = self._db.execute("SELECT * FROM trials ORDER BY trial_id")
            names = [d[0] for d in cursor.description]
            for row in cursor:
                yield {n: _py_value(v, n) for n, v in zip(names, row, strict=True)}
        except sqlite3.DatabaseError as exc:
            raise ConfigError(f"{self.path} is not a readable manigrasp results store ({exc})") from exc

    def results(self) -> Iterator[tuple[TrialKey, TrialResult]]:
        """Every stored trial as (key, result); `ConfigError` on a row that is not a trial."""
        key_fields = [f.name for f in fields(TrialKey)]
        for row in self.rows():
            try:
                key = TrialKey(**{k: row[k] for k in key_fields})  # type: ignore[arg-type]
                rest = {k: v for k, v in row.items() if k not in KEY_COLUMNS}
                yield key, TrialResult.from_flat(rest)
            except (KeyError, TypeError, ValueError) as exc:
                raise ConfigError(f"{self.path}: trial {row.get('trial_id')!r} is not a valid row ({exc})") from exc

    def count(self) -> int:
        """Number of stored trials."""
        return int(self._db.execute("SELECT COUNT(*) FROM trials").fetchone()[0])


def _open_readonly(path: Path) -> sqlite3.Connection:
    """A read-only connection to an existing store (``immutable`` when its folder cannot be written,
    where SQLite could not create the WAL index: nothing else can be writing there)."""
    if not path.is_file():
        raise ConfigError(f"no results store at {path}")
    flags = "mode=ro" if os.access(path.parent, os.W_OK) else "immutable=1"
    try:
        db = sqlite3.connect(f"{path.resolve().as_uri()}?{flags}", uri=True, timeout=60.0)
        db.execute("SELECT COUNT(*) FROM trials").fetchone()
    except sqlite3.DatabaseError as exc:
        raise ConfigError(f"{path} is not a readable manigrasp results store ({exc})") from exc
    return db


def _sql_value(value: object) -> object:
    """SQLite stores NaN as NULL (infinity round-trips as REAL)."""
    return None if isinstance(value, float) and math.isnan(value) else value


def _py_value(value: object, name: str) -> object:
    if value is None:
        return "" if name in ("detail", "last_phase", "fingers_in_contact", "grasp_joints") else math.nan
    return value


def joints_text(joints: np.ndarray | None) -> str:
    """A grasp's joints (2, n_act) as the store keeps them (`TrialResult.grasp_joints`): JSON text with every
    float's shortest exact repr, so a replay executes the very same numbers; "" for None."""
    return "" if joints is None else json.dumps(np.asarray(joints, dtype=float).tolist())


def joints_from_text(text: str) -> np.ndarray | None:
    """Inverse of `joints_text` (None for ""); a text that is not a JSON array of numbers raises ConfigError."""
    if not text:
        return None
    try:
        return np.array(json.loads(text), dtype=float)
    except (TypeError, ValueError) as exc:
        raise ConfigError(f"stored grasp joints are not a JSON array of numbers: {text[:80]!r}") from exc
