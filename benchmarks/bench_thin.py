"""Antipodal candidates on thin and narrow objects: the ranked walk alone vs with the dense pass (step 6).

For each object and seed, `antipodal` (parallel_jaw) is asked for --n candidates twice, side by side:
with `dense_below=0` (the ranked walk of steps 4-5 only) and with the defaults (the dense pass runs
when the walk keeps fewer than min(n, 25)). Printed: candidates found and planning time of each,
per seed, and the smallest count over the seeds (the issue asks for >= 20 with n = 100).

    .venv/bin/python benchmarks/bench_thin.py                         # gelatin box, phone box, scissors; seeds 0-3
    .venv/bin/python benchmarks/bench_thin.py --objects 006_mustard_bottle --seeds 8 --n 20
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from manigrasp import hands, planners  # noqa: E402
from manigrasp.objects import catalog  # noqa: E402

OBJECTS = ("009_gelatin_box", "x01_phone_box", "037_scissors")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--objects", nargs="+", default=list(OBJECTS), help="shipped object names")
    parser.add_argument("--seeds", type=int, default=4, help="planning seeds 0..S-1")
    parser.add_argument("--n", type=int, default=100, help="candidates asked for")
    args = parser.parse_args()
    hand = hands.load("parallel_jaw")
    variants = {"walk only": planners.load("antipodal", dense_below=0), "with dense": planners.load("antipodal")}
    print(f"# antipodal, parallel_jaw, n={args.n}, seeds 0-{args.seeds - 1}; {os.cpu_count()} cores, "
          f"{platform.processor() or platform.machine()}")
    print(f"{'object':18s} {'variant':11s} {'min found':>9s} {'median [s]':>10s}  found per seed")
    for name in args.objects:
        obs = planners.Observation.from_asset(catalog.build(catalog.shipped(name)).asset)
        for label, planner in variants.items():
            results = [planners.plan(planner, obs, hand, args.n, np.random.default_rng(seed))
                       for seed in range(args.seeds)]
            found = [len(r.candidates) for r in results]
            median = statistics.median(r.planning_time_s for r in results)
            print(f"{name:18s} {label:11s} {min(found):9d} {median:10.3f}  {found}", flush=True)


if __name__ == "__main__":
    main()
