"""Grasping from what the cameras see: success and planning time by number of views, and against completion.

    .venv/bin/python benchmarks/bench_partial_view.py [--objects NAME ...] [--views 1 2 3] [--grasps 10]
                                                       [--seed 0] [--timing-n 100] [--timing-only]

Each object (default: the five of configs/perception.yaml) settles on the
table of the standard scene and is seen by k ray-cast cameras
(`CameraSetup(views=k)`: azimuths 30 + 360 i / k deg, 45 deg elevation,
0.55 m, the default depth noise; the noise seeded per object and camera as
the benchmark's point_cloud observation). The antipodal planner plans
`--grasps` candidates on the fused cloud with ``completion="free_space"``
(and, with one view, ``"point_symmetry"``, the old default, for comparison);
each candidate runs under the standard protocol on the true physics. A
planner that returns fewer candidates than asked counts the missing ones as
failures (no_grasp), one that raises counts every one (planner_error), as the benchmark does.

Prints per object and per method: successes / trials, planner errors and trials without a grasp; then
the planning time of `--timing-n` candidates per number of views (median
and max over the objects of the process's CPU time, and the wall time; one
process, BLAS threads limited to one unless OMP_NUM_THREADS says otherwise).
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")  # one core: before numpy loads its BLAS
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import time  # noqa: E402
from collections import defaultdict  # noqa: E402

import numpy as np  # noqa: E402

from manigrasp import planners  # noqa: E402
from manigrasp.bench.observe import observe_with_info  # noqa: E402
from manigrasp.errors import PlannerError  # noqa: E402
from manigrasp.objects import catalog  # noqa: E402
from manigrasp.perception.setup import CameraSetup  # noqa: E402
from manigrasp.protocol import PROTOCOLS, settle_object  # noqa: E402
from manigrasp.protocol.result import Status  # noqa: E402
from manigrasp.sim import build_scene  # noqa: E402

OBJECTS = ("025_mug", "048_hammer", "005_tomato_soup_can", "004_sugar_box", "011_banana")


def methods(views: list[int]) -> list[tuple[str, int, str]]:
    """(label, views, completion) of every compared method."""
    out = [(f"free_space, {k} view{'s' if k > 1 else ''}", k, "free_space") for k in views]
    return out + [("point_symmetry, 1 view", 1, "point_symmetry")] if 1 in views else out


def _timed(planner, obs, hand, n: int, seed: int) -> tuple[float, float]:
    """(wall, CPU) seconds of one planning call of `n` candidates (CPU: this process's, so a busy machine
    does not inflate it)."""
    wall, cpu = time.perf_counter(), time.process_time()
    planners.plan(planner, obs, hand, n, np.random.default_rng(seed))
    return time.perf_counter() - wall, time.process_time() - cpu


def run_object(name: str, views: list[int], grasps: int, seed: int, timing_n: int, simulate: bool = True):
    """{label: statuses}, {views: seconds to plan `timing_n` candidates} for one object (no statuses
    without `simulate`)."""
    asset = catalog.build(catalog.shipped(name)).asset
    scene = build_scene("parallel_jaw", asset)
    protocol = PROTOCOLS.load("standard")
    statuses, timing = {}, {}
    for label, k, completion in methods(views):
        rest = settle_object(scene)
        obs, _ = observe_with_info("point_cloud", asset, rest, scene, seed=seed, camera=CameraSetup(views=k))
        planner = planners.load("antipodal", completion=completion)
        if not simulate:
            if completion == "free_space":
                timing[k] = _timed(planner, obs, scene.hand, timing_n, seed)
            continue
        try:
            found = planners.plan(planner, obs, scene.hand, grasps, np.random.default_rng(seed)).candidates
        except PlannerError:
            statuses[label] = [Status.PLANNER_ERROR] * grasps
        else:
            out = [protocol.run(scene, c, np.random.default_rng([seed, i]), object_pose=rest).status
                   for i, c in enumerate(found)]
            statuses[label] = out + [Status.NO_GRASP] * (grasps - len(found))
        if completion == "free_space":
            timing[k] = _timed(planner, obs, scene.hand, timing_n, seed)
    return statuses, timing


def _planner_failures(out: list[Status]) -> str:
    return (f"planner_error {sum(s is Status.PLANNER_ERROR for s in out)}"
            f"  no_grasp {sum(s is Status.NO_GRASP for s in out)}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--objects", nargs="*", default=list(OBJECTS), help="shipped objects")
    parser.add_argument("--views", nargs="*", type=int, default=[1, 2, 3], help="numbers of cameras compared")
    parser.add_argument("--grasps", type=int, default=10, help="candidates planned and simulated per method")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--timing-n", type=int, default=100, help="candidates of the timed planning call")
    parser.add_argument("--timing-only", action="store_true", help="only the planning times (no simulation)")
    args = parser.parse_args()
    totals: dict[str, list] = defaultdict(list)
    times: dict[int, list[tuple[float, float]]] = defaultdict(list)
    for name in args.objects:
        statuses, timing = run_object(name, args.views, args.grasps, args.seed, args.timing_n, not args.timing_only)
        for label, out in statuses.items():
            totals[label] += out
            print(f"{name:22s} {label:26s} {sum(s is Status.SUCCESS for s in out):3d}/{len(out)}"
                  f"  {_planner_failures(out)}", flush=True)
        for k, seconds in timing.items():
            times[k].append(seconds)
    if totals:
        print("\noverall")
    for label, out in totals.items():
        wins = sum(s is Status.SUCCESS for s in out)
        print(f"  {label:26s} {wins:3d}/{len(out)} = {wins / len(out):.2f}  {_planner_failures(out)}")
    print(f"\nplanning time for {args.timing_n} candidates (free_space), over {len(args.objects)} objects:")
    for k, values in sorted(times.items()):
        wall, cpu = np.array(values).T
        print(f"  {k} view{'s' if k > 1 else ' '}: CPU median {np.median(cpu):.2f} s, max {np.max(cpu):.2f} s "
              f"({np.median(cpu) / k:.2f} s per view); wall median {np.median(wall):.2f} s")


if __name__ == "__main__":
    main()
