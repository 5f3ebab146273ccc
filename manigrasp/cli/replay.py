"""`manigrasp replay`: re-simulate one stored trial from its grasp and seed (optionally recording it)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Register `replay`."""
    p = subparsers.add_parser(
        "replay", help="re-simulate one trial of a run (or a `label` dataset) and report its status",
        description="Rebuild TRIAL_ID's scene from RUN_DIR/run.json, settle the object, execute the stored grasp "
                    "(TCP pose, width, pre-shape) with the trial's seed under the run's protocol, and compare the "
                    "status with the stored one. Exit 0 if they agree, 1 if not. A trial id is "
                    "object/hand/planner/observation/protocol/NNNN (NNNN: the grasp's rank), as in results.sqlite's "
                    "trial_id column and a `label` dataset's trial_id labels.")
    p.add_argument("run_dir", type=Path, metavar="RUN_DIR")
    p.add_argument("trial_id", metavar="TRIAL_ID")
    p.add_argument("--record", type=Path, metavar="FILE.rrd", help="write a rerun recording of the replay")
    p.add_argument("--base", type=Path, metavar="DIR",
                   help="directory the run's config gave relative mesh paths against (default: the config file's "
                        "folder, as run.json records it; the working directory for a run that does not record it)")
    p.set_defaults(func=_replay)


def _replay(args: argparse.Namespace) -> int:
    from manigrasp.bench.replay import replay_trial

    replay = replay_trial(args.run_dir, args.trial_id, record=args.record, base=args.base)
    stored, now = replay.stored, replay.replayed
    print(f"{replay.trial_id}: stored {stored.status.value}, replayed {now.status.value}"
          f"{' (' + now.detail + ')' if now.detail else ''}")
    if replay.recording is not None:
        print(f"recording: {replay.recording}", file=sys.stderr)
    if replay.object_pose_error > 1e-6:
        print(f"warning: the re-settled object differs from the stored pose by {replay.object_pose_error:.2g}; "
              "this scene is not the run's (another manigrasp, mujoco or object build?)", file=sys.stderr)
    return 0 if replay.same_status else 1
