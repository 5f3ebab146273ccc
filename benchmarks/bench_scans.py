"""Scan vs recipe, rigid vs compliant pads, side by side: success counts and trials per second.

For each pad model (rigid, then compliant) one run of the five shipped real YCB scans and their
recipe twins (`configs/scans.yaml`, narrowed by the options) goes into OUT/<pads>/; then the
table prints, per hand x planner x object, successes/trials on the scan and on the recipe under
each pad model, the gap in points (recipe - scan) and whether it is within 10 points; and per
pad model the trials per second of the whole run (same objects, same machine, one after the other).

    .venv/bin/python benchmarks/bench_scans.py --out /tmp/bench_scans                  # parallel_jaw, antipodal
    .venv/bin/python benchmarks/bench_scans.py --out /tmp/bs --hands parallel_jaw panda --planners antipodal random
    .venv/bin/python benchmarks/bench_scans.py --out /tmp/bs --config quick             # any config: speed side by side

Runs resume (a re-run prints the stored results without simulating again; then trials/s is of the
trials simulated by this invocation, so time a fresh OUT).
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

from manigrasp.bench.config import load_config  # noqa: E402
from manigrasp.bench.report import load_results, summarize  # noqa: E402
from manigrasp.bench.runner import run_benchmark  # noqa: E402
from manigrasp.bench.twins import GAP_POINTS, twin_rows  # noqa: E402
from manigrasp.paths import configs_dir  # noqa: E402

MODES = ("rigid", "compliant")


def _run(config_path: Path, overrides: list[str], out: Path, jobs: int) -> tuple[dict, float, int]:
    config = load_config(config_path, overrides)
    start = time.perf_counter()
    summary = run_benchmark(config, out, jobs=jobs, base=config_path.parent, progress=False)
    seconds = time.perf_counter() - start
    report = summarize(load_results(out))
    return report.groups, seconds, summary.ran


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, required=True, help="folder of the two runs")
    parser.add_argument("--config", default="scans", help="shipped config name or YAML path (default scans)")
    parser.add_argument("--hands", nargs="+", default=["parallel_jaw"])
    parser.add_argument("--planners", nargs="+", default=["antipodal"])
    parser.add_argument("--grasps", type=int, default=20, help="grasps per object")
    parser.add_argument("--objects", nargs="+", default=None, help="objects (default: the config's)")
    parser.add_argument("--jobs", type=int, default=1)
    args = parser.parse_args()
    path = Path(args.config) if args.config.endswith(".yaml") else configs_dir() / f"{args.config}.yaml"
    common = [f"hands=[{', '.join(args.hands)}]", f"planners=[{', '.join(args.planners)}]",
              f"grasps_per_object={args.grasps}"] + ([f"objects=[{', '.join(args.objects)}]"] if args.objects else [])
    print(f"# {path.name}: {' '.join(common)}; {args.jobs} job(s); {os.cpu_count()} cores, "
          f"{platform.processor() or platform.machine()}")
    groups, speed = {}, {}
    for mode in MODES:
        groups[mode], seconds, ran = _run(path, [*common, f"scene.pads={mode}"], args.out / mode, args.jobs)
        speed[mode] = (ran, seconds)
    print("\n## trials per second (whole run: planning + simulation)")
    for mode, (ran, seconds) in speed.items():
        rate = ran / seconds if ran else float("nan")
        print(f"{mode:9s} {ran:5d} trials simulated in {seconds:7.1f} s = {rate:6.3f} trials/s")
    (r_ran, r_s), (c_ran, c_s) = speed["rigid"], speed["compliant"]
    if r_ran and c_ran:
        print(f"compliant is {(c_s / c_ran) / (r_s / r_ran):.2f}x the rigid time per trial")
    print(f"\n## scan vs recipe (successes/trials; gap = recipe - scan in points; ok: |gap| <= {GAP_POINTS:g})")
    print(f"{'hand':13s} {'planner':10s} {'object':20s} " + " ".join(
        f"{m + ' scan':>14s} {m + ' recipe':>16s} {'gap':>5s} {'ok':>3s}" for m in MODES))
    rows = {mode: {(r.method, r.recipe): r for r in twin_rows(groups[mode])} for mode in MODES}
    for key in sorted(rows["rigid"].keys() | rows["compliant"].keys()):
        (hand, planner, _), recipe = key
        cells = []
        for mode in MODES:
            r = rows[mode].get(key)
            cells.append("-" if r is None else f"{r.scan_rate.successes:>8d}/{r.scan_rate.trials:<5d} "
                         f"{r.recipe_rate.successes:>10d}/{r.recipe_rate.trials:<5d} {r.gap_points:+5.0f} "
                         f"{'yes' if r.within else 'no':>3s}")
        print(f"{hand:13s} {planner:10s} {recipe:20s} " + " ".join(cells))
    others = sorted({k[3] for k in groups["rigid"]} - {r for (_, r) in rows["rigid"]}
                    - {r.scan for r in rows["rigid"].values()})
    if others:
        print("\n## other objects (successes/trials): " + "rigid vs compliant")
        for (hand, planner, obs, obj), rate in sorted(groups["rigid"].items()):
            if obj in others:
                c = groups["compliant"].get((hand, planner, obs, obj))
                print(f"{hand:13s} {planner:10s} {obj:20s} {rate.successes:3d}/{rate.trials:<3d} "
                      f"{'-' if c is None else f'{c.successes:3d}/{c.trials}'}")


if __name__ == "__main__":
    main()
