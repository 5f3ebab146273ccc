"""Choosing a run's recordings and opening them in the rerun viewer, or saying how to, headless.

    >>> paths = select_recordings(run_dir, status="dropped_perturb")
    >>> outcome = open_viewer(paths)       # never raises for a missing display or viewer
    >>> print(outcome.message)
"""

from __future__ import annotations

import os
import shlex
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

from manigrasp.errors import ConfigError
from manigrasp.protocol.result import Status
from manigrasp.record.policy import SUFFIX, trial_file_name

RECORDINGS = "recordings"


@dataclass(frozen=True)
class ViewOutcome:
    """What `open_viewer` did.

    Attributes:
        opened: True if a viewer process was started.
        command: the command that opens the recordings (run it yourself when `opened` is False).
        message: one line for the user.
    """

    opened: bool
    command: str
    message: str


def recordings_dir(run_dir: str | Path) -> Path:
    """RUN_DIR/recordings (`ConfigError` if the run has none)."""
    folder = Path(run_dir) / RECORDINGS
    if not Path(run_dir).is_dir():
        raise ConfigError(f"no run directory {run_dir}")
    if not folder.is_dir() or not any(folder.glob(f"*{SUFFIX}")):
        raise ConfigError(f"run {run_dir} has no recordings: re-run its `manigrasp bench CONFIG --out {run_dir}` "
                          "command with --record failures|successes|all|N (its stored trials are re-simulated "
                          "from their stored grasp and seed and recorded)")
    return folder


def _statuses_from_store(run_dir: Path) -> dict[str, str] | None:
    """file name -> status of every stored trial, or None without a results store."""
    path = run_dir / "results.sqlite"
    if not path.is_file():
        return None
    from manigrasp.bench.store import ResultsStore

    with ResultsStore(path) as store:
        return {trial_file_name(key.trial_id): result.status.value for key, result in store.results()}


def _status_of(path: Path, stored: dict[str, str] | None) -> str | None:
    if stored is not None and path.name in stored:
        return stored[path.name]
    from manigrasp.record.readback import summarize

    return summarize(path).status


def select_recordings(run_dir: str | Path, trial: str | None = None, status: str | None = None) -> list[Path]:
    """The recordings of a run: all, the one of trial id `trial`, or those whose trial ended with `status`.

    Statuses come from RUN_DIR/results.sqlite, or from the recordings themselves without it.
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


def has_display() -> bool:
    """Whether a graphical viewer can open here (macOS / Windows, or X11 / Wayland on Linux)."""
    if sys.platform in ("darwin", "win32"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def viewer_executable() -> str:
    """The `rerun` CLI: next to this Python interpreter, else on PATH, else plain "rerun"."""
    beside = Path(sys.executable).parent / "rerun"
    if beside.is_file():
        return str(beside)
    return shutil.which("rerun") or "rerun"


def viewer_command(paths: list[Path]) -> list[str]:
    """The command that opens `paths` in the rerun viewer."""
    return [viewer_executable(), *(str(p) for p in paths)]


def open_viewer(paths: list[Path], display: bool | None = None) -> ViewOutcome:
    """Start the rerun viewer on `paths` (detached) if a display exists; otherwise only return the command.

    Never raises for a missing display or viewer: the outcome says what to run.
    """
    command = viewer_command(paths)
    text = shlex.join(command)
    if not (has_display() if display is None else display):
        return ViewOutcome(False, text, f"no display here; to view {len(paths)} recording(s) run:\n  {text}")
    try:
        subprocess.Popen(command, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                         start_new_session=True)
    except OSError as exc:
        return ViewOutcome(False, text, f"could not start the viewer ({exc}); run:\n  {text}")
    return ViewOutcome(True, text, f"opened {len(paths)} recording(s) in the rerun viewer")
