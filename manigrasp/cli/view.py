"""`manigrasp view RUN_DIR [--trial ID | --status STATUS]`: open a run's recordings in the rerun viewer."""

from __future__ import annotations

import argparse
from pathlib import Path


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Register `view`."""
    p = subparsers.add_parser(
        "view", help="open a run's recordings in the rerun viewer (headless: print the command)",
        description="Open RUN_DIR/recordings/*.rrd in the rerun viewer: all of them, one trial, or the trials "
                    "that ended with a status. Without a display it prints the command to run instead.")
    p.add_argument("run_dir", type=Path, metavar="RUN_DIR")
    which = p.add_mutually_exclusive_group()
    which.add_argument("--trial", metavar="ID", help="a trial id (object/hand/planner/observation/protocol/0003)")
    which.add_argument("--status", help="trials that ended with this status, e.g. dropped_perturb")
    p.add_argument("--print-only", action="store_true", help="only print the command, even with a display")
    p.set_defaults(func=_view)


def _view(args: argparse.Namespace) -> int:
    from manigrasp.bench.recordings import select_recordings
    from manigrasp.record.view import open_viewer

    paths = select_recordings(args.run_dir, trial=args.trial, status=args.status)
    outcome = open_viewer(paths, display=False if args.print_only else None)
    print(outcome.message)
    return 0
