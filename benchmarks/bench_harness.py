"""The harness's measured figures (issue 6): trials/s per worker and its share of the physics limit,
speed-up from 1 to 2 workers, peak memory per worker.

    .venv/bin/python benchmarks/bench_harness.py [--config configs/quick.yaml] [--grasps 10] [--jobs 2]

(a) One worker (in this process): `run_benchmark(config, jobs=1)` on the config
    with `grasps_per_object` set to `--grasps`; trials/s. Then, side by side,
    the raw `mj_step` rate of the same compiled scenes (the worker's own cached
    scenes) for the same number of steps as each object's trials took: each
    scene reset with the hand closed on the object at the first candidate of
    its first planner group, stepped with no Python in the loop. The share of
    the physics limit is (physics time those steps need at the raw rate) /
    (wall time of the run), overall and for the trials alone (trial wall times
    summed, leaving out planning, settling and scene compilation). Also where
    the wall time went: inside `mj_step` (timed around each call), the
    analytic metrics of planned and simulated contacts, planning, and the rest
    (controllers, checks, result store, process pool).
(b) The same run with `--jobs` workers (a process pool): wall-time speed-up,
    and the speed-up of the trial throughput from the first stored result to
    the last (leaving out the start-up: object cache check, spawning and
    importing the workers, first planning).
(c) Peak resident memory: of this process after the one-worker run
    (`getrusage`), and of each worker process of the pool (its RSS polled every
    0.1 s with psutil; the largest is printed).

Objects are built (or loaded from the cache) before any timing.
"""

from __future__ import annotations

import argparse
import collections
import os
import resource
import sqlite3
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path

import mujoco
import numpy as np
import psutil

from manigrasp.bench import runner, worker
from manigrasp.bench.config import load_config
from manigrasp.bench.runner import run_benchmark, validate
from manigrasp.bench.trials import Group
from manigrasp.objects import catalog
from manigrasp.protocol import phases, trial

ROOT = Path(__file__).resolve().parent.parent


class Timer:
    """Adds up the time spent in a module-level function, by wrapping it where it is looked up."""

    def __init__(self, *places: tuple[object, str]) -> None:
        self.places = places
        self.seconds, self.calls, self.steps = 0.0, 0, 0
        self._originals = [getattr(module, name) for module, name in places]

    def __enter__(self) -> Timer:
        for (module, name), original in zip(self.places, self._originals, strict=True):
            setattr(module, name, self._wrap(original))
        return self

    def _wrap(self, original: Callable) -> Callable:
        def timed(*args: object, **kwargs: object) -> object:
            start = time.perf_counter()
            try:
                return original(*args, **kwargs)
            finally:
                self.seconds += time.perf_counter() - start
                self.calls += 1
                self.steps += int(kwargs.get("nstep", 1))  # type: ignore[call-overload]

        return timed

    def __exit__(self, *exc: object) -> None:
        for (module, name), original in zip(self.places, self._originals, strict=True):
            setattr(module, name, original)


class PeakMemory:
    """Polls the resident memory of this process's children every `period` [s]; keeps each one's peak."""

    def __init__(self, period: float = 0.1) -> None:
        self.period, self.peaks = period, {}
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._poll, daemon=True)

    def _poll(self) -> None:
        me = psutil.Process()
        while not self._stop.is_set():
            for child in me.children(recursive=True):
                try:
                    rss = child.memory_info().rss
                except psutil.Error:
                    continue
                self.peaks[child.pid] = max(self.peaks.get(child.pid, 0), rss)
            self._stop.wait(self.period)

    def __enter__(self) -> PeakMemory:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join()


def _rows(run_dir: Path) -> list[dict]:
    with sqlite3.connect(run_dir / "results.sqlite") as db:
        db.row_factory = sqlite3.Row
        return [dict(r) for r in db.execute("SELECT * FROM trials")]


def _raw_rate(group: Group, steps: int) -> float:
    """mj_step/s of the group's compiled scene with the hand closed on the object, for `steps` steps."""
    scene = worker.scene_for(group)
    plan = worker.plan_group(group)
    pose = np.asarray(plan.candidates[0].pose, float) if plan.candidates else None
    if pose is None:
        pose = np.diag([1.0, -1.0, -1.0, 1.0])
        pose[:3, 3] = plan.object_pose[:3, 3]
    scene.reset(mount=pose, object_pose=plan.object_pose, synergy=1.0)
    model, data = scene.model, scene.data
    start = time.perf_counter()
    mujoco.mj_step(model, data, nstep=steps)
    return steps / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--config", default=str(ROOT / "configs" / "quick.yaml"))
    parser.add_argument("--grasps", type=int, default=10, help="grasps_per_object (quick.yaml has 20)")
    parser.add_argument("--jobs", type=int, default=2, help="workers of the parallel run")
    args = parser.parse_args()
    config = load_config(args.config, [f"grasps_per_object={args.grasps}"])
    groups = validate(config)
    catalog.build_many(list({g.object_source.name: g.object_source for g in groups}.values()), jobs=1)
    print(f"config {args.config} with grasps_per_object={args.grasps}: {len(groups)} groups, "
          f"{sum(g.n_grasps for g in groups)} trials; cores {os.cpu_count()}, load {os.getloadavg()[0]:.2f}")

    with tempfile.TemporaryDirectory() as tmp:
        physics_timer = Timer((mujoco, "mj_step"))
        metric_timer = Timer((trial, "planned_metrics"), (phases, "simulated_metrics"))
        plan_timer = Timer((runner, "plan_group"))
        one_stamps: list[float] = []
        with physics_timer, metric_timer, plan_timer:
            one = run_benchmark(config, Path(tmp) / "one", jobs=1, progress=False, in_process=True,
                                on_result=lambda key, result: one_stamps.append(time.perf_counter()))
        rss_self = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        rows = _rows(Path(tmp) / "one")
        steps = collections.Counter()
        for row in rows:
            steps[row["object"]] += int(row["sim_steps"])
        trial_wall = sum(float(r["wall_time_s"]) for r in rows)
        print("\n(a) one worker")
        print(f"{'object':<22} {'trials':>6} {'steps':>8} {'raw steps/s':>12} {'physics s':>10}")
        physics = 0.0
        for name, n in steps.items():
            group = next(g for g in groups if g.object_source.name == name)
            rate = _raw_rate(group, max(n, 1))
            physics += n / rate
            count = sum(r["object"] == name for r in rows)
            print(f"{name:<22} {count:>6} {n:>8} {rate:>12.0f} {n / rate:>10.2f}")
        total = sum(steps.values())
        print(f"run: {one.ran} trials in {one.seconds:.2f} s = {one.ran / one.seconds:.2f} trials/s per worker; "
              f"{total} trial steps = {total / one.seconds:.0f} steps/s")
        print(f"share of the physics limit (raw-rate physics time / wall): whole run {physics / one.seconds:.3f}, "
              f"trials alone {physics / trial_wall:.3f} (trial wall {trial_wall:.2f} s)")
        rest = one.seconds - physics_timer.seconds - metric_timer.seconds - plan_timer.seconds
        print(f"wall {one.seconds:.2f} s = inside mj_step {physics_timer.seconds:.2f} s "
              f"({physics_timer.seconds / one.seconds:.3f}; {physics_timer.steps} steps incl. settling) "
              f"+ contact metrics {metric_timer.seconds:.2f} s ({metric_timer.seconds / one.seconds:.3f}) "
              f"+ planning and settling {plan_timer.seconds:.2f} s ({plan_timer.seconds / one.seconds:.3f}; "
              f"its settling steps counted in mj_step too) + the rest {rest:.2f} s ({rest / one.seconds:.3f})")

        start = time.perf_counter()
        many_stamps: list[float] = []
        with PeakMemory() as memory:
            many = run_benchmark(config, Path(tmp) / "many", jobs=args.jobs, progress=False,
                                 on_result=lambda key, result: many_stamps.append(time.perf_counter()))
        wall = time.perf_counter() - start
        workers = sorted(memory.peaks.values(), reverse=True)[:args.jobs]
        same = sorted((r["trial_id"], r["status"]) for r in rows) == sorted(
            (r["trial_id"], r["status"]) for r in _rows(Path(tmp) / "many"))
        print(f"\n(b) load {os.getloadavg()[0]:.2f}; {args.jobs} workers: {many.ran} trials in {wall:.2f} s = "
              f"{many.ran / wall:.2f} trials/s; "
              f"speed-up {one.seconds / wall:.2f}x over one worker (statuses identical: {same})")
        steady = [(len(t) - 1) / (t[-1] - t[0]) for t in (one_stamps, many_stamps)]
        print(f"    from first to last result: one worker {steady[0]:.2f} trials/s, {args.jobs} workers "
              f"{steady[1]:.2f} trials/s: speed-up {steady[1] / steady[0]:.2f}x; start-up to the first result "
              f"{many_stamps[0] - start:.2f} s with {args.jobs} workers")
        print(f"\n(c) peak memory: one-worker run (this process) {rss_self:.0f} MB; "
              f"pool workers {', '.join(f'{w / 2**20:.0f}' for w in workers)} MB")


if __name__ == "__main__":
    main()
