"""Planning time per shipped object: `antipodal` asked for 100 collision-free candidates (parallel_jaw),
median of --repeats runs, against the textbook's O(n^2) search on the same surface samples.

The textbook search gets the same mesh and the same number of samples
(`n_samples` points with their normals, drawn as our planner draws them).
"ratio" is textbook time / our whole planning time; "search ratio" is textbook
time / our pair search alone (the like-for-like part: the textbook stops at pairs). Our time includes everything: mesh
sampling, ray casting, epsilon of every pair, scene compilation for the
MuJoCo collision checks, the checks, NMS and the candidates' metrics.

    .venv/bin/python benchmarks/bench_planners.py                 # whole shipped set
    .venv/bin/python benchmarks/bench_planners.py --objects 025_mug --repeats 5
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from manigrasp import hands, planners  # noqa: E402
from manigrasp.objects import catalog, recipes  # noqa: E402
from manigrasp.planners.geometry import SmoothNormals, sample_surface  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from textbook_antipodal import TextbookAntipodalPlanner  # noqa: E402


def ours(obs: planners.Observation, hand: hands.Hand, repeats: int) -> tuple[float, int]:
    """Median planning time [s] over `repeats` seeds, and the candidate count of the first."""
    planner = planners.load("antipodal")
    times, counts = [], []
    for seed in range(repeats):
        result = planners.plan(planner, obs, hand, 100, np.random.default_rng(seed))
        times.append(result.planning_time_s)
        counts.append(len(result.candidates))
    return statistics.median(times), counts[0]


def pair_search(obs: planners.Observation, hand: hands.Hand, repeats: int) -> tuple[float, int]:
    """Median time [s] of our pair search alone (sampling, normals, ray casts, cone/width/reach tests,
    thinning): the like-for-like counterpart of the textbook search; and the pairs found."""
    planner, mesh = planners.load("antipodal"), obs.world_mesh()
    times, found = [], 0
    for seed in range(repeats):
        start = time.perf_counter()
        found = len(planner.pairs(mesh, hand, np.random.default_rng(seed)))
        times.append(time.perf_counter() - start)
    return statistics.median(times), found


def textbook(obs: planners.Observation, n_samples: int) -> tuple[float, int]:
    """Time [s] of the textbook search on `n_samples` surface samples, and the grasps it returns."""
    mesh = obs.world_mesh()
    samples = sample_surface(mesh, n_samples, np.random.default_rng(0))
    normals = SmoothNormals(mesh).at(samples.faces, samples.barycentric)
    start = time.perf_counter()
    grasps = TextbookAntipodalPlanner().plan_grasp(samples.points, normals)
    return time.perf_counter() - start, len(grasps)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--objects", nargs="*", default=list(recipes.names()), help="object names (default: all)")
    parser.add_argument("--repeats", type=int, default=3, help="planning runs per object (median)")
    args = parser.parse_args()
    hand = hands.load("parallel_jaw")
    n_samples = planners.load("antipodal").n_samples
    print(f"# antipodal, parallel_jaw, n=100 asked, {n_samples} samples; {os.cpu_count()} cores, "
          f"{platform.processor() or platform.machine()}")
    print(f"{'object':22s} {'ours [s]':>9s} {'found':>6s} {'pairs [s]':>10s} {'pairs':>6s} "
          f"{'textbook [s]':>13s} {'tb grasps':>10s} {'ratio':>7s} {'search ratio':>13s}")
    ours_all, ratios, search_ratios = [], [], []
    for name in args.objects:
        obs = planners.Observation.from_asset(catalog.build(catalog.shipped(name)).asset)
        t_ours, found = ours(obs, hand, args.repeats)
        t_pairs, n_pairs = pair_search(obs, hand, args.repeats)
        t_book, book_found = textbook(obs, n_samples)
        ours_all.append(t_ours)
        ratios.append(t_book / t_ours)
        search_ratios.append(t_book / t_pairs)
        print(f"{name:22s} {t_ours:9.3f} {found:6d} {t_pairs:10.4f} {n_pairs:6d} {t_book:13.2f} {book_found:10d} "
              f"{t_book / t_ours:7.1f} {t_book / t_pairs:13.0f}", flush=True)
    print(f"median: ours {statistics.median(ours_all):.3f} s per object (target < 0.5 s); "
          f"textbook / ours (whole plan) {statistics.median(ratios):.1f}x; "
          f"textbook / our pair search {statistics.median(search_ratios):.0f}x")


if __name__ == "__main__":
    main()
