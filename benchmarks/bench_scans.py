"""Scan vs recipe, rigid vs compliant pads, side by side: success counts and trials per second.

For each pad model (default: rigid, then compliant; `--modes` adds e.g. `compliant:E=3e6` (compliant pads
with a Young's modulus of 3 MPa, `scene.pad_modulus`), `compliant:mu=0.5` (their rubber's friction,
`scene.pad_friction`) or `compliant:pitch=0.02`) one run of the five shipped real YCB scans and their
recipe twins (`configs/scans.yaml`, narrowed by the options) goes into OUT/<pads>/; then the
table prints, per hand x planner x object, successes/trials on the scan and on the recipe under
each pad model, the gap in points (recipe - scan) and whether it is within 10 points; and per
pad model the trials per second of the whole run (same objects, same machine, one after the other).

    .venv/bin/python benchmarks/bench_scans.py --out /tmp/bench_scans                  # parallel_jaw, antipodal
    .venv/bin/python benchmarks/bench_scans.py --out /tmp/bs --hands parallel_jaw panda --planners antipodal random
    .venv/bin/python benchmarks/bench_scans.py --out /tmp/bs --config quick             # any config: speed side by side
    .venv/bin/python benchmarks/bench_scans.py --out /tmp/bs --modes rigid compliant compliant:mu=0.5
    .venv/bin/python benchmarks/bench_scans.py --out /tmp/bs --modes compliant --seeds 0 1 2 \
        --objects 003_cracker_box_scan 003_cracker_box   # 60 trials per object, pooled over the seeds

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


MODE_KEYS = {"E": "pad_modulus", "mu": "pad_friction", "pitch": "pad_pitch"}


def mode_overrides(mode: str) -> list[str]:
    """Config overrides of a pad mode: "rigid", "compliant", or "compliant:" followed by comma-separated
    settings E=<Young's modulus, Pa>, mu=<pad friction>, pitch=<element pitch, m> (a bare number is E)."""
    pads, _, rest = mode.partition(":")
    out = [f"scene.pads={pads}"]
    for item in filter(None, rest.split(",")):
        key, eq, value = item.rpartition("=")
        key = key if eq else "E"
        if key not in MODE_KEYS:
            raise SystemExit(f"unknown pad setting {key!r} in mode {mode!r}; available: {', '.join(MODE_KEYS)}")
        out.append(f"scene.{MODE_KEYS[key]}={float(value)}")
    return out


def _run(config_path: Path, overrides: list[str], out: Path, jobs: int,
         seeds: list[int] | None = None) -> tuple[dict, float, int]:
    """One run per seed (None: the config's seed, into `out`; else into out/s<seed>), pooled: the groups' rates
    over every seed's trials, the seconds and the trials simulated."""
    runs = [(out, [])] if seeds is None else [(out / f"s{seed}", [f"seed={seed}"]) for seed in seeds]
    results, seconds, ran = [], 0.0, 0
    for folder, seed in runs:
        config = load_config(config_path, [*overrides, *seed])
        start = time.perf_counter()
        summary = run_benchmark(config, folder, jobs=jobs, base=config_path.parent, progress=False)
        seconds += time.perf_counter() - start
        ran += summary.ran
        results.extend(load_results(folder))
    return summarize(results).groups, seconds, ran


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, required=True, help="folder of the two runs")
    parser.add_argument("--config", default="scans", help="shipped config name or YAML path (default scans)")
    parser.add_argument("--hands", nargs="+", default=["parallel_jaw"])
    parser.add_argument("--planners", nargs="+", default=["antipodal"])
    parser.add_argument("--grasps", type=int, default=20, help="grasps per object")
    parser.add_argument("--objects", nargs="+", default=None, help="objects (default: the config's)")
    parser.add_argument("--jobs", type=int, default=1)
    parser.add_argument("--seeds", nargs="+", type=int, default=None,
                        help="root seeds, one run each (OUT/<mode>/s<seed>), pooled per object (default: the config's)")
    parser.add_argument("--modes", nargs="+", default=list(MODES),
                        help="pad modes, first is the reference: rigid, compliant, compliant:E=..,mu=..,pitch=..")
    args = parser.parse_args()
    modes = args.modes
    path = Path(args.config) if args.config.endswith(".yaml") else configs_dir() / f"{args.config}.yaml"
    common = [f"hands=[{', '.join(args.hands)}]", f"planners=[{', '.join(args.planners)}]",
              f"grasps_per_object={args.grasps}"] + ([f"objects=[{', '.join(args.objects)}]"] if args.objects else [])
    print(f"# {path.name}: {' '.join(common)}; {args.jobs} job(s); {os.cpu_count()} cores, "
          f"{platform.processor() or platform.machine()}" + (f"; seeds {args.seeds}" if args.seeds else ""))
    groups, speed = {}, {}
    for mode in modes:
        folder = args.out / mode.replace(":", "_").replace(",", "_")
        groups[mode], seconds, ran = _run(path, [*common, *mode_overrides(mode)], folder, args.jobs, args.seeds)
        speed[mode] = (ran, seconds)
    print("\n## trials per second (whole run: planning + simulation)")
    for mode, (ran, seconds) in speed.items():
        rate = ran / seconds if ran else float("nan")
        print(f"{mode:9s} {ran:5d} trials simulated in {seconds:7.1f} s = {rate:6.3f} trials/s")
    r_ran, r_s = speed[modes[0]]
    for mode in modes[1:]:
        c_ran, c_s = speed[mode]
        if r_ran and c_ran:
            print(f"{mode} is {(c_s / c_ran) / (r_s / r_ran):.2f}x the {modes[0]} time per trial")
    print(f"\n## scan vs recipe (successes/trials; gap = recipe - scan in points; ok: |gap| <= {GAP_POINTS:g})")
    print(f"{'hand':13s} {'planner':10s} {'object':20s} " + " ".join(
        f"{m + ' scan':>14s} {m + ' recipe':>16s} {'gap':>5s} {'ok':>3s}" for m in modes))
    rows = {mode: {(r.method, r.recipe): r for r in twin_rows(groups[mode])} for mode in modes}
    for key in sorted(set().union(*(rows[m].keys() for m in modes))):
        (hand, planner, *_), recipe = key
        cells = []
        for mode in modes:
            r = rows[mode].get(key)
            cells.append("-" if r is None else f"{r.scan_rate.successes:>8d}/{r.scan_rate.trials:<5d} "
                         f"{r.recipe_rate.successes:>10d}/{r.recipe_rate.trials:<5d} {r.gap_points:+5.0f} "
                         f"{'yes' if r.within else 'no':>3s}")
        print(f"{hand:13s} {planner:10s} {recipe:20s} " + " ".join(cells))
    ref = modes[0]
    others = sorted({k[-1] for k in groups[ref]} - {r for (_, r) in rows[ref]} - {r.scan for r in rows[ref].values()})
    if others:
        print("\n## other objects (successes/trials): " + " vs ".join(modes))
        for key, rate in sorted(groups[ref].items()):
            if key[-1] in others:
                cells = [f"{rate.successes:3d}/{rate.trials:<3d}"] + [
                    "-" if (c := groups[m].get(key)) is None else f"{c.successes:3d}/{c.trials:<3d}" for m in modes[1:]]
                print(f"{key[0]:13s} {key[1]:10s} {key[-1]:20s} " + " ".join(f"{c:>10s}" for c in cells))


if __name__ == "__main__":
    main()
