"""`manigrasp report | compare | export`: summarise a stored run, gate it on a baseline, export its table."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from manigrasp.cli.output import format_table, print_json
from manigrasp.errors import ConfigError


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Register `report`, `compare` and `export`."""
    p = subparsers.add_parser(
        "report", help="summarise a run: success rates per hand x planner, failure modes, metric AUCs, report.md",
        description="Print the run's rates per hand x planner (x observation x protocol) and per object (95 % "
                    "Wilson intervals), failure modes, the median planning call and each metric's AUC for success "
                    "per hand x planner (95 % bootstrap interval), a warning if the run is incomplete, the "
                    "object x hand pairs the config leaves out (an object's `exclude`) with their reasons, and "
                    "write report.md with PNG plots into RUN_DIR (or --out). The stored results are "
                    "only read: a read-only RUN_DIR works (its report.md is then skipped unless --out).")
    p.add_argument("run_dir", type=Path, metavar="RUN_DIR")
    p.add_argument("--json", action="store_true",
                   help="print the summary and the run's config and versions as JSON, and write nothing "
                        "(the format of a baseline: `manigrasp report RUN_DIR --json > baseline.json`)")
    p.add_argument("--out", type=Path, metavar="DIR", help="write report.md and the plots here (default RUN_DIR)")
    p.set_defaults(func=_report)

    p = subparsers.add_parser(
        "compare", help="exit 1 if a success rate is significantly lower than a baseline's",
        description="One-sided two-proportion z-tests per hand x planner x observation x protocol x object group "
                    "present in both (Holm-corrected across groups), per hand x planner x observation x protocol "
                    "over its groups in both (Holm-corrected across them), and over all groups in both pooled; "
                    "each of the three families at a third of alpha, so that a run as good as its baseline fails by "
                    "chance less often than alpha. Groups found on one side only are listed; an incomplete run is "
                    "noted. Exit 0: no significant regression; 1: a regression; 2: cannot judge (different "
                    "protocol, planner, hand, object, physics or grasps_per_object, an object x hand in both that "
                    "one side leaves out (`exclude`), or cameras where perception groups are compared; no common "
                    "trials, a malformed baseline, alpha outside (0, 1)).")
    p.add_argument("run_dir", type=Path, metavar="RUN_DIR")
    p.add_argument("baseline", type=Path, metavar="BASELINE",
                   help="a baseline run directory or JSON file (`manigrasp report RUN_DIR --json > FILE`)")
    p.add_argument("--alpha", type=float, default=0.05, help="significance level in (0, 1) (default 0.05)")
    p.set_defaults(func=_compare)

    p = subparsers.add_parser(
        "export", help="export a run's results table (one row per trial) as CSV or Parquet",
        description="Write RUN_DIR's trials as a table: key columns, a boolean success, the executed grasp's pose "
                    "in the world (position + wxyz quaternion), jaw width or pre-shape, metrics, timings; units "
                    "in column names. Parquet needs the parquet extra (pyarrow).")
    p.add_argument("run_dir", type=Path, metavar="RUN_DIR")
    p.add_argument("--format", choices=("csv", "parquet"), default="csv", help="file format (default csv)")
    p.add_argument("--out", type=Path, metavar="FILE", help="output file (default RUN_DIR/results.FORMAT)")
    p.set_defaults(func=_export)


def _report(args: argparse.Namespace) -> int:
    return print_report(args.run_dir, as_json=args.json, out_dir=args.out)


def print_report(run_dir: Path, as_json: bool, out_dir: Path | None = None) -> int:
    """Summarise the run in `run_dir`: print the tables and write report.md and plots (or print JSON only).

    report.md goes to `out_dir` (default `run_dir`); a read-only run directory is read, and its report
    not written unless `out_dir` is given.
    """
    from dataclasses import asdict

    from manigrasp.bench.completeness import completeness
    from manigrasp.bench.markdown import left_out_of, warning_lines
    from manigrasp.bench.report import load_results, summarize
    from manigrasp.bench.rundir import config_dir, load_meta

    meta = load_meta(run_dir)
    results = load_results(run_dir)
    report = summarize(results)
    done = completeness(results, meta, config_dir(run_dir))
    if as_json:
        run = {k: meta.get(k) for k in ("config", "seed", "versions", "git_commit", "started")}
        if isinstance(meta.get("effective"), dict):
            run["effective"] = meta["effective"]
        if meta.get("resumed_with_other_code"):
            run["resumed_with_other_code"] = meta["resumed_with_other_code"]
        pairs = left_out_of(meta)
        print_json({"run": run, "completeness": {**asdict(done), "complete": done.complete}, **report.to_json(),
                    **({"left_out": [asdict(p) for p in pairs]} if pairs else {})})
        return 0
    warnings = warning_lines(meta, done, report)
    for line in warnings:  # first, as report.md puts them: before any figure is read
        print(f"WARNING: {line}")
    _print_tables(report, meta)
    for pair in left_out_of(meta):
        print(f"left out by the config: {pair.hand} x {pair.object} ({pair.reason})")
    if warnings:  # the tables may have scrolled them away
        print(f"WARNING: {len(warnings)} warning(s) printed before the tables")
    target = Path(out_dir) if out_dir is not None else Path(run_dir)
    if out_dir is None and not os.access(target, os.W_OK):
        print(f"manigrasp: note: {run_dir} is read-only: report.md and plots not written (give --out DIR)",
              file=sys.stderr)
        return 0
    from manigrasp.bench.markdown import write_markdown

    try:
        target.mkdir(parents=True, exist_ok=True)
    except OSError as exc:  # a file where the folder should be, or no permission
        raise ConfigError(f"--out {target}: cannot write the report there ({exc.strerror})") from None
    print(f"report: {write_markdown(report, results, target, meta, done)}")
    return 0


def _print_tables(report, meta: dict) -> None:
    from manigrasp.bench.markdown import (
        auc_rows,
        in_protocol_order,
        lead_lines,
        method_cells,
        method_headers,
        pooled_line,
        protocol_order,
    )
    from manigrasp.bench.report import PLANNING_TIME_HEADER, format_planning_time, format_rate, format_stored_share

    report = in_protocol_order(report, protocol_order(report, meta))
    headers = method_headers(report)
    rows = [[*method_cells(report, g[:4]), g[4], r.trials, r.successes, format_rate(r), _top_modes(r.failure_modes)]
            for g, r in report.groups.items()]
    print(format_table([*headers, "object", "trials", "successes", "rate [95% CI]", "top failure modes"], rows))
    print()
    print(format_table([*headers, "trials", "successes", "rate [95% CI]",
                        "top failure modes", PLANNING_TIME_HEADER],
                       [[*method_cells(report, m), r.trials, r.successes, format_rate(r), _top_modes(r.failure_modes),
                         format_planning_time(r)] for m, r in report.by_method.items()]))
    for m, e in report.pose_errors.items():
        if not e.objects:
            print(f"pose errors {'/'.join(method_cells(report, m))}: every one of {e.failed} pose estimate"
                  f"{'s' if e.failed != 1 else ''} failed")
            continue
        rotation = (f"rotation median {e.median_rotation_deg:.1f} deg (p90 {e.p90_rotation_deg:.1f}) over the "
                    f"{e.objects - e.symmetric} {'not known to have' if e.unrecorded else 'without'} a symmetry, "
                    if e.objects > e.symmetric else "")
        notes = "".join(f"; {note}" for note in e.notes())
        good = format_stored_share(e.share_good, percent=True)
        print(f"pose errors {'/'.join(method_cells(report, m))}: {rotation}translation median "
              f"{e.median_translation_mm:.1f} mm (p90 {e.p90_translation_mm:.1f}); {good} of "
              f"{e.objects + e.failed} pose estimate{'s' if e.objects + e.failed != 1 else ''} (one per object, or "
              f"object x resting pose{notes}) good: translation < 1 cm and rotation < 5 deg, or ADD-S < 5 mm for "
              f"an object with a symmetry")
    print("\nEach metric's ROC AUC for success [95% bootstrap CI]; n: simulated trials with a value (successes)")
    print(format_table([*headers, "metric", "n (successes)", "AUC [95% CI]"], auc_rows(report)))
    print()
    for line in lead_lines(report, protocol_order(report, meta)):
        print(line)
    print(pooled_line(report))


def _top_modes(modes: dict[str, int]) -> str:
    top = sorted(modes.items(), key=lambda kv: -kv[1])[:3]
    return ", ".join(f"{m} {n}" for m, n in top) or "-"


def _compare(args: argparse.Namespace) -> int:
    from manigrasp.bench.compare import P_NOTE, compare_sides, load_side
    from manigrasp.bench.report import format_rate

    verdict = compare_sides(load_side(args.run_dir), load_side(args.baseline), args.alpha)
    print(format_table(
        ["group", "new", "baseline", "difference", "p (adjusted)", "verdict"],
        [[c.group, f"{c.new.successes}/{c.new.trials} = {format_rate(c.new)}",
          f"{c.base.successes}/{c.base.trials} = {format_rate(c.base)}", f"{c.test.difference:+.3f}",
          f"{c.adjusted_p:.3g}", "REGRESSION" if c.regression else "ok"] for c in verdict.comparisons]))
    for groups, where in ((verdict.only_new, "in the run only (not compared)"),
                          (verdict.only_base, "in the baseline only (not compared)"),
                          (verdict.partial, "held only in part by one side (not compared: a ranked planner's first "
                                            "candidates are not all of them; finish the run)")):
        if groups:
            print(f"\n{len(groups)} group(s) {where}: " + ", ".join("/".join(g) for g in groups))
    for note in verdict.notes:
        print(f"note: {note}")
    print(f"\n{P_NOTE}.\n{verdict.summary(args.alpha)}")
    return 1 if verdict.regressions else 0


def _export(args: argparse.Namespace) -> int:
    from manigrasp.bench.export import export
    from manigrasp.bench.rundir import load_meta
    from manigrasp.bench.store import ResultsStore
    from manigrasp.runfiles import STORE_NAME

    load_meta(args.run_dir)
    if not (args.run_dir / STORE_NAME).is_file():
        raise ConfigError(f"{args.run_dir} holds no {STORE_NAME}: nothing to export")
    out = args.out or args.run_dir / f"results.{args.format}"
    if out.suffix != f".{args.format}":
        raise ConfigError(f"--out {out} does not end in .{args.format}")
    if not out.parent.is_dir() or not os.access(out.parent, os.W_OK):
        raise ConfigError(f"cannot write {out}: {out.parent} is not a writable folder (give --out FILE)")
    with ResultsStore(args.run_dir / STORE_NAME, readonly=True) as store:
        written = export(store.rows(), out)
    print(f"exported {written}")
    return 0
