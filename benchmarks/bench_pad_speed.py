"""Rigid vs compliant pads, trial for trial in one process: trials per second and what each trial costs.

Each group of the config (default `quick`) is run twice, once with `scene.pads=rigid` and once with
`scene.pads=compliant`: both are planned, then their trials alternate (rigid trial i, compliant trial i,
...), so a machine whose load drifts (a shared one) slows both modes alike. Printed per group: the
seconds per trial of each mode (the trial only: approach, close, lift, perturbations and simulated
metrics, as the worker runs it) and their successes; then, over the whole config, trials per second
of each mode with and without planning, and the ratio compliant / rigid. In this process: no worker
pool, no time budgets. Deterministic results for a seed; the timings are what this machine gave.

    .venv/bin/python benchmarks/bench_pad_speed.py                       # quick: 200 trials per mode
    .venv/bin/python benchmarks/bench_pad_speed.py --objects 004_sugar_box --grasps 5
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

from manigrasp.bench import worker  # noqa: E402
from manigrasp.bench.config import load_config  # noqa: E402
from manigrasp.bench.trials import groups  # noqa: E402
from manigrasp.paths import configs_dir  # noqa: E402
from manigrasp.protocol.result import Status  # noqa: E402

MODES = ("rigid", "compliant")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--config", default="quick", help="shipped config name or YAML path (default quick)")
    parser.add_argument("--objects", nargs="+", default=None, help="objects (default: the config's)")
    parser.add_argument("--planners", nargs="+", default=None, help="planners (default: the config's)")
    parser.add_argument("--grasps", type=int, default=None, help="grasps per object (default: the config's)")
    args = parser.parse_args()
    path = Path(args.config) if args.config.endswith(".yaml") else configs_dir() / f"{args.config}.yaml"
    overrides = ([f"objects=[{', '.join(args.objects)}]"] if args.objects else []) + (
        [f"planners=[{', '.join(args.planners)}]"] if args.planners else []) + (
        [f"grasps_per_object={args.grasps}"] if args.grasps else [])
    config = load_config(path, overrides)
    print(f"# {path.name} {' '.join(overrides)}: trials alternate rigid / compliant in one process; "
          f"{os.cpu_count()} cores")
    print(f"{'object':22s} {'planner':10s} " + " ".join(f"{m + ' s/trial':>17s} {m + ' ok':>13s}" for m in MODES)
          + f" {'ratio':>6s}")
    plan_s = {m: 0.0 for m in MODES}
    trial_s = {m: 0.0 for m in MODES}
    trials = {m: 0 for m in MODES}
    for group in groups(config, path.parent):
        pair = {m: dataclasses.replace(group, scene=dataclasses.replace(group.scene, pads=m)) for m in MODES}
        plans, seconds, ok = {}, {m: 0.0 for m in MODES}, {m: 0 for m in MODES}
        for mode, g in pair.items():
            start = time.perf_counter()
            plans[mode] = worker.plan_group(g)
            plan_s[mode] += time.perf_counter() - start
        for index in range(group.n_grasps):
            for mode, g in pair.items():
                start = time.perf_counter()
                _, result = worker.run_trial(g, index, plans[mode])
                seconds[mode] += time.perf_counter() - start
                ok[mode] += result.status is Status.SUCCESS
        for mode in MODES:
            trial_s[mode] += seconds[mode]
            trials[mode] += group.n_grasps
        cells = " ".join(f"{seconds[m] / group.n_grasps:17.3f} {ok[m]:>10d}/{group.n_grasps:<2d}" for m in MODES)
        print(f"{group.object_label or group.object_source.name:22s} {group.planner.name:10s} {cells} "
              f"{seconds['compliant'] / seconds['rigid']:6.2f}", flush=True)
    print()
    for mode in MODES:
        print(f"{mode:9s} {trials[mode]} trials: {trials[mode] / trial_s[mode]:.3f} trials/s simulated, "
              f"{trials[mode] / (trial_s[mode] + plan_s[mode]):.3f} trials/s with planning "
              f"({plan_s[mode]:.1f} s planning)")
    print(f"compliant / rigid time per trial: {trial_s['compliant'] / trial_s['rigid']:.2f}x simulated, "
          f"{(trial_s['compliant'] + plan_s['compliant']) / (trial_s['rigid'] + plan_s['rigid']):.2f}x with planning")


if __name__ == "__main__":
    main()
