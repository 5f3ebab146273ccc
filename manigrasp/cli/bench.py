"""`manigrasp bench | report | compare`: run the benchmark, summarise it, gate on a baseline."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from manigrasp.cli.output import format_table, print_json
from manigrasp.errors import ConfigError


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Register `bench`, `report` and `compare`."""
    p = subparsers.add_parser(
        "bench", help="run a benchmark config (resumes an interrupted run)",
        description="Plan grasps and run every trial of CONFIG in simulation; results go to RUN_DIR/results.sqlite "
                    "as each trial finishes. Re-running the same command resumes: stored trials are skipped.")
    p.add_argument("config",
                   help="a YAML config file, or the name of a shipped one (quick, standard, dexterous, perception)")
    p.add_argument("overrides", nargs="*", metavar="key=value",
                   help="config overrides, dotted for nested keys (grasps_per_object=5 scene.timestep=0.001)")
    p.add_argument("--out", required=True, type=Path, metavar="RUN_DIR", help="run directory")
    p.add_argument("--jobs", type=int, default=1, help="worker processes (default 1)")
    p.add_argument("--executor", choices=("local", "ray"), default="local",
                   help="local process pool (default) or a Ray cluster")
    p.add_argument("--address", help="Ray cluster address (default: start a local Ray instance)")
    p.add_argument("--export", choices=("parquet", "csv"), help="also export the results table")
    p.add_argument("--record", default="none", metavar="none|failures|successes|all|N",
                   help="write RUN_DIR/recordings/<trial>.rrd (rerun) for these trials; N: the first N of each "
                        "object x hand x planner (default none). Open them with `manigrasp view RUN_DIR`")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=_bench)

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


def resolve_config(name: str) -> Path:
    """A config path, or a shipped config name ("quick" -> configs/quick.yaml)."""
    path = Path(name)
    if path.is_file():
        return path
    from manigrasp.paths import configs_dir

    shipped = configs_dir() / f"{name}.yaml"
    if shipped.is_file():
        return shipped
    names = sorted(p.stem for p in configs_dir().glob("*.yaml"))
    raise ConfigError(f"no config file {name!r}; shipped configs: {', '.join(names)}")


def _bench(args: argparse.Namespace) -> int:
    from manigrasp.bench.config import load_config
    from manigrasp.bench.runner import run_benchmark

    path = resolve_config(args.config)
    config = load_config(path, args.overrides)
    summary = run_benchmark(config, args.out, jobs=max(1, args.jobs), executor=args.executor,
                            address=args.address, base=path.parent, progress=not args.quiet, record=args.record)
    print(f"{summary.ran} trials run, {summary.already_done} already stored, {summary.total} in all "
          f"({summary.seconds:.0f} s)", file=sys.stderr)
    if args.export:
        from manigrasp.bench.store import ResultsStore, export

        with ResultsStore(args.out / "results.sqlite") as store:
            exported = export(store.rows(), args.out / f"results.{args.export}")
        print(f"exported {exported}", file=sys.stderr)
    return _report(argparse.Namespace(run_dir=args.out, json=False))


def _load_report(path: Path):
    from manigrasp.bench.report import load_results, report_from_json, summarize

    if path.is_file():
        return report_from_json(json.loads(path.read_text()))
    if not (path / "results.sqlite").is_file():
        raise ConfigError(f"{path} is neither a run directory nor a report JSON file")
    return summarize(load_results(path))


def _report(args: argparse.Namespace) -> int:
    from manigrasp.bench.markdown import write_markdown
    from manigrasp.bench.report import format_rate, load_results, summarize
    from manigrasp.bench.rundir import load_meta

    meta = load_meta(args.run_dir)
    results = load_results(args.run_dir)
    report = summarize(results)
    markdown = write_markdown(report, results, args.run_dir, meta)
    if args.json:
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
