"""Opening recordings in the rerun viewer, or saying how to, headless.

    >>> outcome = open_viewer(paths)       # never raises for a missing display or viewer
    >>> print(outcome.message)

A run's recordings are chosen by `manigrasp.bench.recordings.select_recordings`.
"""

from __future__ import annotations

import os
import shlex
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path


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
