"""Object-set build times: cold with 1 and 2 jobs, then warm (cached), side by side.

Each cold run uses its own empty cache folder, so CoACD runs for every
non-convex object; the warm run repeats the 2-job build on a filled cache.

    .venv/bin/python benchmarks/bench_objects.py            # whole shipped set
    .venv/bin/python benchmarks/bench_objects.py --objects 025_mug 024_bowl
"""

from __future__ import annotations

import argparse
import os
import platform
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

from manigrasp.objects import catalog, recipes  # noqa: E402


def timed_build(names: list[str], jobs: int, cache: Path) -> tuple[float, list[catalog.BuildOutcome]]:
    """Wall time [s] and outcomes of building `names` with `jobs` workers into `cache`."""
    start = time.perf_counter()
    outcomes = catalog.build_many([catalog.shipped(n) for n in names], jobs=jobs, cache_root=cache)
    return time.perf_counter() - start, outcomes


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--objects", nargs="*", default=list(recipes.names()), help="object names (default: all)")
    args = parser.parse_args()
    print(f"# {len(args.objects)} objects, {os.cpu_count()} cores, {platform.processor() or platform.machine()}")
    with tempfile.TemporaryDirectory() as tmp:
        cold1, per_object = timed_build(args.objects, 1, Path(tmp) / "cold1")
        cold2, _ = timed_build(args.objects, 2, Path(tmp) / "cold2")
        warm, outcomes = timed_build(args.objects, 2, Path(tmp) / "cold2")
        warm1, _ = timed_build(args.objects, 1, Path(tmp) / "cold2")
    print(f"{'object':22s} {'hulls':>5s} {'coverage':>8s} {'cold s':>7s}")
    for o in per_object:
        a = o.result.asset
        print(f"{o.name:22s} {a.n_parts:5d} {a.metadata['coverage']:8.3f} {o.result.seconds:7.2f}")
    assert all(o.result.cached for o in outcomes), "warm build ran CoACD"
    print(f"cold build, 1 job : {cold1:7.1f} s")
    print(f"cold build, 2 jobs: {cold2:7.1f} s  (speed-up {cold1 / cold2:.2f}x)")
    print(f"warm build, 2 jobs: {warm:7.2f} s  (includes starting 2 worker processes)")
    print(f"warm build, 1 job : {warm1:7.2f} s  (target: under 2 s)")


if __name__ == "__main__":
    main()
