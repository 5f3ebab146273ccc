"""`manigrasp label`: generate a physics-labelled grasp dataset (native format and ACRONYM's layout)."""

from __future__ import annotations

import argparse
import sys

from manigrasp.cli import run_dir_path
from manigrasp.cli.evaluate import FORMATS_HELP


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Register `label`."""
    p = subparsers.add_parser(
        "label", help="plan many grasps per object x hand, simulate each, and write them with their labels",
        description="Run CONFIG like `manigrasp bench` (resumable: re-run the same command to continue; parallel "
                    "with --jobs or Ray), then write every trial's grasp in the object's frame with its label "
                    "(status, success, trial id, seed, measures, the object's settled pose) to RUN_DIR/grasps/: "
                    "<object>__<hand>__<planner>.json (or .npz; a dexterous grasp's joints included) and, for parallel "
                    "hands only, .h5 in ACRONYM's layout (a parallel-jaw format; the summary says when none is "
                    "written and why). "
                    "Set the number of candidates with grasps_per_object=N.",
        epilog=FORMATS_HELP, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("config", help="a YAML config file, or the name of a shipped one")
    p.add_argument("overrides", nargs="*", metavar="key=value",
                   help="config overrides (grasps_per_object=2000 protocol=lift)")
    p.add_argument("--out", required=True, type=run_dir_path, metavar="RUN_DIR",
                   help="run directory (the dataset goes to RUN_DIR/grasps)")
    p.add_argument("--jobs", type=int, default=1, help="worker processes (default 1)")
    p.add_argument("--executor", choices=("local", "ray"), default="local", help="local process pool or Ray")
    p.add_argument("--address", help="Ray cluster address (default: a local Ray instance)")
    p.add_argument("--npz", action="store_true", help="write the native files as .npz instead of .json")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=_label)


def _label(args: argparse.Namespace) -> int:
    from manigrasp.bench.config import load_config
    from manigrasp.bench.label import label
    from manigrasp.cli import check_jobs
    from manigrasp.cli.bench import resolve_config
    from manigrasp.cli.output import format_table

    path = resolve_config(args.config)
    config = load_config(path, args.overrides)
    check_jobs(args.jobs)
    summary = label(config, args.out, jobs=args.jobs, executor=args.executor, address=args.address,
                    base=path.parent, progress=not args.quiet, native_suffix=".npz" if args.npz else ".json")
    rows = [(name, f"{ok}/{n}", f"{ok / n:.1%}" if n else "-")
            for name, (ok, n) in sorted(summary.success_share().items())]
    print(format_table(("object", "success", "share"), rows))
    print(f"{summary.written} grasps written, {summary.labelled_now} of them labelled now ({summary.ran} trials run, "
          f"{summary.already_done} already stored); {summary.labelled_per_second:.2f} labelled/s "
          f"({summary.seconds:.0f} s, {args.jobs} job(s)); {without_grasp_note(summary.without_grasp)}",
          file=sys.stderr)
    for item in summary.exported:
        note = f" ({item.note})" if item.note else ""
        print("  " + ", ".join(str(f) for f in item.files) + note, file=sys.stderr)
    return 0


def without_grasp_note(counts: dict[str, int]) -> str:
    """"3 trials not written, without a grasp or a label (no_grasp 2, timeout 1)": the trials that executed no
    grasp (a planner that found too few, failed or overran its budget) and the harness faults (a bug of
    manigrasp: physics did not judge the grasp), by status."""
    total = sum(counts.values())
    if not total:
        return "every trial had a grasp and a label"
    by_status = ", ".join(f"{status} {n}" for status, n in sorted(counts.items(), key=lambda kv: (-kv[1], kv[0])))
    return f"{total} trial{'s' if total != 1 else ''} not written, without a grasp or a label ({by_status})"
