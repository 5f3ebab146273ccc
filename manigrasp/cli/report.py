"""`manigrasp report | compare`: summarise a stored run, gate it on a baseline."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from manigrasp.cli.output import format_table, print_json
from manigrasp.errors import ConfigError


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Register `report` and `compare`."""
    p = subparsers.add_parser("report", help="summarise a run: success rates, failure modes, plots, report.md")
    p.add_argument("run_dir", type=Path, metavar="RUN_DIR")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    p.set_defaults(func=_report)

    p = subparsers.add_parser(
        "compare", help="exit 1 if a success rate is significantly lower than a baseline's",
        description="One-sided two-proportion z-tests, overall and per group (Holm-corrected across groups).")
    p.add_argument("run_dir", type=Path, metavar="RUN_DIR")
    p.add_argument("baseline", type=Path, metavar="BASELINE", help="a baseline run directory or report JSON file")
    p.add_argument("--alpha", type=float, default=0.05, help="significance level (default 0.05)")
    p.set_defaults(func=_compare)


def _load_report(path: Path):
    from manigrasp.bench.report import load_results, report_from_json, summarize

    if path.is_file():
        return report_from_json(json.loads(path.read_text()))
    if not (path / "results.sqlite").is_file():
        raise ConfigError(f"{path} is neither a run directory nor a report JSON file")
    return summarize(load_results(path))


def _report(args: argparse.Namespace) -> int:
    return print_report(args.run_dir, as_json=args.json)


def print_report(run_dir: Path, as_json: bool) -> int:
    """Summarise the run in `run_dir`: write report.md and plots, print the tables (or JSON)."""
    from manigrasp.bench.markdown import write_markdown
    from manigrasp.bench.report import format_rate, load_results, summarize
    from manigrasp.bench.rundir import load_meta

    meta = load_meta(run_dir)
    results = load_results(run_dir)
    report = summarize(results)
    markdown = write_markdown(report, results, run_dir, meta)
    if as_json:
        print_json(report.to_json())
        return 0
    rows = [[h, p, o, obj, r.trials, r.successes, format_rate(r), _top_modes(r.failure_modes)]
            for (h, p, o, obj), r in report.groups.items()]
    rows += [[h, p, o, "ALL", r.trials, r.successes, format_rate(r), _top_modes(r.failure_modes)]
             for (h, p, o), r in report.by_method.items()]
    print(format_table(["hand", "planner", "observation", "object", "trials", "successes", "rate [95% CI]",
                        "top failure modes"], rows))
    for (h, p, o), e in report.pose_errors.items():
        print(f"pose errors {h}/{p}/{o}: rotation median {e.median_rotation_deg:.1f} deg "
              f"(p90 {e.p90_rotation_deg:.1f}), translation median {e.median_translation_mm:.1f} mm "
              f"(p90 {e.p90_translation_mm:.1f}), {e.share_within_5deg_1cm:.0%} of {e.objects} objects "
              "with ADD-S < 5 mm and translation < 1 cm")
    print(f"\noverall: {report.overall.successes}/{report.overall.trials} = {format_rate(report.overall)}")
    print("metric AUC for success: " + ", ".join(f"{k} {v:.2f}" for k, v in report.auc.items()))
    print(f"report: {markdown}")
    return 0


def _top_modes(modes: dict[str, int]) -> str:
    top = sorted(modes.items(), key=lambda kv: -kv[1])[:3]
    return ", ".join(f"{m} {n}" for m, n in top) or "-"


def _compare(args: argparse.Namespace) -> int:
    from manigrasp.bench.compare import compare
    from manigrasp.bench.report import format_rate

    rows = compare(_load_report(args.run_dir), _load_report(args.baseline), args.alpha)
    print(format_table(
        ["group", "new", "baseline", "difference", "p (adjusted)", "verdict"],
        [[c.group, format_rate(c.new), format_rate(c.base), f"{c.test.difference:+.3f}", f"{c.adjusted_p:.3g}",
          "REGRESSION" if c.regression else "ok"] for c in rows]))
    regressions = [c for c in rows if c.regression]
    print(f"\n{len(regressions)} significant regression(s) at alpha = {args.alpha}")
    return 1 if regressions else 0
