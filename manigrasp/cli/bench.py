"""`manigrasp bench`: run a benchmark config (the summary is `manigrasp report`'s, in cli/report.py)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from manigrasp.cli import check_jobs, run_dir_path
from manigrasp.errors import ConfigError


class _IntermixedParser(argparse.ArgumentParser):
    """A parser whose positionals may come anywhere among the options (``bench quick --out X seed=1``)."""

    _inner = False

    def parse_known_args(self, args=None, namespace=None):  # noqa: ANN001, ANN201 - argparse's signature
        if self._inner:  # parse_known_intermixed_args calls back into parse_known_args
            return super().parse_known_args(args, namespace)
        self._inner = True
        try:
            return self.parse_known_intermixed_args(args, namespace)
        finally:
            self._inner = False


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Register `bench`."""
    p = subparsers.add_parser(
        "bench", help="run a benchmark config (resumes an interrupted run)",
        description="Plan grasps and run every trial of CONFIG in simulation; results go to RUN_DIR/results.sqlite "
                    "as each trial finishes. Re-running the same command resumes: stored trials are skipped; a "
                    "different config (or changed mesh files) in the same RUN_DIR is refused, naming the keys that "
                    "differ. A config that names a planner, hand or protocol as `module:attribute` imports and "
                    "runs that module's code: treat such a config as a program and run only configs you trust.",
        epilog="Bad input (a wrong type, a value out of range, a duplicate entry) stops before anything is written, "
               "with a one-line error and exit code 2. A planner or trial that fails, hangs past trial_timeout_s "
               "or crashes its worker is a recorded status, and the run goes on.")
    p.__class__ = _IntermixedParser
    p.add_argument("config",
                   help="a YAML config file, or the name of a shipped one "
                        "(quick, standard, dexterous, perception, scans, regression_dexterous)")
    p.add_argument("overrides", nargs="*", metavar="key=value",
                   help="config overrides, anywhere on the line, dotted for nested keys (grasps_per_object=5 "
                        "scene.timestep=0.001); a list field takes one value or a list (objects=mug, "
                        "hands=[panda,parallel_jaw]); protocols=[standard,lift] runs several protocols side by "
                        "side and replaces the config's protocol: (protocol=NAME replaces its protocols:); "
                        "hands=[...] names the hands of the run and drops the config's exclusions (an object's "
                        "exclude:) of the others")
    p.add_argument("--out", required=True, type=run_dir_path, metavar="RUN_DIR", help="run directory")
    p.add_argument("--jobs", type=int, default=1,
                   help="worker processes (default 1; capped at the cores of this machine)")
    p.add_argument("--executor", choices=("local", "ray"), default="local",
                   help="local process pool (default) or a Ray cluster")
    p.add_argument("--address", help="Ray cluster address (default: start a local Ray instance)")
    p.add_argument("--export", choices=("parquet", "csv"), help="also export the results table")
    p.add_argument("--record", default="none", metavar="none|failures|successes|all|N",
                   help="write RUN_DIR/recordings/<trial>.rrd (rerun) for these trials; N: the first N of each "
                        "object x hand x planner (default none). Trials already stored are re-simulated from their "
                        "stored grasp and seed and recorded after the run. A recording that cannot be written is "
                        "reported and never changes a result. Open them with `manigrasp view RUN_DIR`")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=_bench)


def resolve_config(name: str) -> Path:
    """A config path, or a shipped config name ("quick" -> configs/quick.yaml)."""
    path = Path(name)
    if path.is_file():
        return path
    from manigrasp.paths import configs_dir

    shipped = configs_dir() / f"{name}.yaml"
    if shipped.is_file():
        return shipped
    from manigrasp.registry import nearest

    names = sorted(p.stem for p in configs_dir().glob("*.yaml"))
    hint = nearest(name, names)
    raise ConfigError(f"no config file {name!r}{f' (did you mean {hint!r}?)' if hint else ''}; shipped configs: "
                      f"{', '.join(names)}")


def _bench(args: argparse.Namespace) -> int:
    from manigrasp.bench.config import load_config
    from manigrasp.bench.runner import run_benchmark

    path = resolve_config(args.config)
    config = load_config(path, args.overrides)
    check_jobs(args.jobs)
    from manigrasp.bench import extras

    extras.check(config, args.executor, args.export)  # an extra the run needs: one line before any trial
    summary = run_benchmark(config, args.out, jobs=args.jobs, executor=args.executor,
                            address=args.address, base=path.parent, progress=not args.quiet, record=args.record)
    print(f"{summary.ran} trials run, {summary.already_done} already stored, {summary.total} in all "
          f"({summary.seconds:.0f} s)", file=sys.stderr)
    if summary.record_note:
        print(summary.record_note, file=sys.stderr)
    if args.export:
        from manigrasp.bench.export import export
        from manigrasp.bench.store import ResultsStore
        from manigrasp.runfiles import STORE_NAME

        with ResultsStore(args.out / STORE_NAME) as store:
            exported = export(store.rows(), args.out / f"results.{args.export}")
        print(f"exported {exported}", file=sys.stderr)
    from manigrasp.cli.report import print_report

    return print_report(args.out, as_json=False)
