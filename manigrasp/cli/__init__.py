"""The `manigrasp` command line: parse, call the library, print, exit.

Each command group lives in its own module with an ``add_parser(subparsers)``
function that registers its sub-commands and sets ``func`` on them. A
`ManigraspError` becomes a one-line message on stderr and exit code 2; a Ctrl-C, at any point, one line and
exit code 130.
"""

from __future__ import annotations

import argparse
import importlib
import os
import signal
import sys
import threading
import warnings
from contextlib import contextmanager
from pathlib import Path

from manigrasp import __version__
from manigrasp.errors import ManigraspError

# Command-group modules, in the order they appear in --help.
_GROUPS = ("objects", "hands", "plan", "bench", "evaluate", "label", "replay", "report", "perceive", "view")


def build_parser() -> argparse.ArgumentParser:
    """The top-level argument parser with every command group."""
    parser = argparse.ArgumentParser(
        prog="manigrasp",
        description="A MuJoCo-based simulated grasping benchmark.",
    )
    parser.add_argument("--version", action="version", version=f"manigrasp {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    for group in _GROUPS:
        module = importlib.import_module(f"manigrasp.cli.{group}")
        module.add_parser(subparsers)
    return parser


def run_dir_path(text: str) -> Path:
    """argparse type of a run directory: an empty path (`--out ""`) is refused (it named the current folder)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("the run directory must not be empty")
    return Path(text)


def check_jobs(jobs: int) -> None:
    """Refuse a `--jobs` below 1 (bench, evaluate, label, objects build), one line, before any work."""
    from manigrasp.errors import ConfigError

    if jobs < 1:
        raise ConfigError(f"--jobs must be >= 1, got {jobs}")


def _one_line_warning(message: Warning | str, category: type[Warning], *_: object, **__: object) -> str:
    """A warning as the CLI prints it: one line, no source location."""
    return f"manigrasp: warning: {message}\n"


INTERRUPTED = "manigrasp: interrupted"


def _exit_interrupted(signum: int, frame: object) -> None:
    """SIGINT while the commands' modules are imported: the process ends here, exit code 130 (nothing has begun)."""
    os.write(2, f"{INTERRUPTED}\n".encode())
    os._exit(130)


@contextmanager
def _interrupt_exits():
    """A Ctrl-C in the block ends the process at once (`_exit_interrupted`) instead of raising KeyboardInterrupt:
    libraries imported there guard their optional imports with ``except BaseException`` (trimesh: networkx,
    scipy...), which swallowed the KeyboardInterrupt, and the command ran on to its end and exit code 0. Only in
    the main thread with Python's own handler in place (SIGINT ignored, as in a background job, stays ignored)."""
    if threading.current_thread() is not threading.main_thread() or (
            signal.getsignal(signal.SIGINT) is not signal.default_int_handler):
        yield
        return
    signal.signal(signal.SIGINT, _exit_interrupted)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, signal.default_int_handler)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the `manigrasp` console script; returns the exit code (130 on Ctrl-C, at any point)."""
    try:
        with _interrupt_exits():  # (a KeyboardInterrupt there was swallowed, or printed an import traceback)
            parser = build_parser()  # imports every command's module
    except KeyboardInterrupt:
        print(INTERRUPTED, file=sys.stderr)
        return 130
    args = parser.parse_args(argv)
    if not hasattr(args, "func"):
        parser.print_help()
        return 2
    formatwarning, warnings.formatwarning = warnings.formatwarning, _one_line_warning
    try:
        return int(args.func(args) or 0)
    except ManigraspError as exc:
        print(f"manigrasp: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(INTERRUPTED, file=sys.stderr)
        return 130
    except BrokenPipeError:  # the reader of stdout went away (`manigrasp objects list | head -1`): no traceback
        try:  # nor at exit, when Python flushes stdout into the closed pipe
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        except (OSError, ValueError, AttributeError):  # stdout without a file descriptor (captured)
            pass
        return 0
    finally:
        warnings.formatwarning = formatwarning


if __name__ == "__main__":
    sys.exit(main())
