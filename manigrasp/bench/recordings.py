"""Choosing a run's recordings (RUN_DIR/recordings) by trial id or by the status the trial ended with.

    >>> paths = select_recordings(run_dir, status="dropped_perturb")
    >>> outcome = open_viewer(paths)       # manigrasp.record.view

Here, not in `record`, because it reads the run's results store (`record` does not import `bench`).
"""

from __future__ import annotations

from pathlib import Path

from manigrasp.bench.store import ResultsStore
from manigrasp.errors import ConfigError
from manigrasp.protocol.result import Status
from manigrasp.record.policy import SUFFIX, trial_file_name
from manigrasp.runfiles import RECORDINGS_DIR, STORE_NAME


def recordings_dir(run_dir: str | Path) -> Path:
    """RUN_DIR/recordings (`ConfigError` if the run has none)."""
    folder = Path(run_dir) / RECORDINGS_DIR
    if not Path(run_dir).is_dir():
        raise ConfigError(f"no run directory {run_dir}")
    if not folder.is_dir() or not any(folder.glob(f"*{SUFFIX}")):
        raise ConfigError(f"run {run_dir} has no recordings: re-run its `manigrasp bench CONFIG --out {run_dir}` "
                          "command with --record failures|successes|all|N (its stored trials are re-simulated "
                          "from their stored grasp and seed and recorded), or record one trial with `manigrasp "
                          f"replay {run_dir} TRIAL_ID --record FILE.rrd` (any run, `evaluate`'s too)")
    return folder


def _statuses_from_store(run_dir: Path) -> dict[str, str] | None:
    """file name -> status of every stored trial, or None without a results store."""
    path = run_dir / STORE_NAME
    if not path.is_file():
        return None
    with ResultsStore(path) as store:
        return {trial_file_name(key.trial_id): result.status.value for key, result in store.results()}


def _status_of(path: Path, stored: dict[str, str] | None) -> str | None:
    if stored is not None and path.name in stored:
        return stored[path.name]
    from manigrasp.record.readback import summarize

    return summarize(path).status


def select_recordings(run_dir: str | Path, trial: str | None = None, status: str | None = None) -> list[Path]:
    """The recordings of a run: all, the one of trial id `trial`, or those whose trial ended with `status`.

    Statuses come from RUN_DIR/results.sqlite (`STORE_NAME`), or from the recordings themselves without it.
    Raises `ConfigError` for an unknown status or when nothing matches (listing what exists).
    """
    folder = recordings_dir(run_dir)
    files = sorted(folder.glob(f"*{SUFFIX}"))
    if trial is not None:
        wanted = {trial_file_name(trial), trial if trial.endswith(SUFFIX) else trial + SUFFIX}
        found = [p for p in files if p.name in wanted]
        if not found:
            sample = ", ".join(p.name for p in files[:5])
            raise ConfigError(f"no recording of trial {trial!r} in {folder} (there are {len(files)}, e.g. {sample}); "
                              f"`manigrasp replay {run_dir} {trial} --record FILE.rrd` records it")
        return found
    if status is None:
        return files
    valid = [s.value for s in Status]
    if status not in valid:
        raise ConfigError(f"unknown status {status!r}; available: {', '.join(valid)}")
    stored = _statuses_from_store(Path(run_dir))
    found = [p for p in files if _status_of(p, stored) == status]
    if not found:
        raise ConfigError(f"no recording of a trial with status {status!r} in {folder}; re-run the run's `manigrasp "
                          "bench` command with --record failures (or all) to record its stored trials")
    return found
