"""Labelled grasps per second per core (`manigrasp label`) on the quick objects with parallel_jaw, and the
share of the time spent outside physics.

    nice -n 10 .venv/bin/python benchmarks/bench_label.py [--grasps 20] [--jobs 1] [--protocol standard]
                                                        [--profile-grasps 5]

(a) `manigrasp.bench.label.label` on configs/quick.yaml's objects, hand parallel_jaw, planner antipodal,
    `--grasps` candidates per object, with `--jobs` worker processes, into a fresh temporary run
    directory: labelled grasps per second of wall time, divided by the number of jobs (per core), and
    the time of the exporter (native JSON + ACRONYM HDF5) alone. The machine may be shared, so the CPU
    time of this process and its workers is given too: grasps per CPU-second is the per-core figure
    that does not depend on other load.
(b) The same work in this process (`--profile-grasps` per object: plan each group, run its trials), once
    timed plainly (CPU time per plan and per trial), then under cProfile with a CPU-time clock, to split
    the time: inside MuJoCo's C functions (every `mujoco._functions` /
    `mujoco._structs` call: mj_step, mj_forward, contact queries...) versus everything else (Python
    control loop and checks, planning, analytic metrics, settling, result building). The largest
    non-physics functions (own time) are listed. cProfile's own overhead inflates the Python share a
    little; (a) is the un-instrumented throughput.

Objects are built (or loaded from the cache) before any timing.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import cProfile  # noqa: E402
import pstats  # noqa: E402
import tempfile  # noqa: E402
import threading  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import psutil  # noqa: E402
import yaml  # noqa: E402

from manigrasp.bench.config import parse_config  # noqa: E402
from manigrasp.paths import configs_dir  # noqa: E402

PHYSICS_MODULES = ("mujoco._functions", "mujoco._structs", "mujoco._callbacks")


def quick_config(grasps: int, protocol: str):
    """configs/quick.yaml's objects with parallel_jaw and the antipodal planner."""
    quick = yaml.safe_load((configs_dir() / "quick.yaml").read_text())
    return parse_config({"name": "bench_label", "objects": quick["objects"], "hands": ["parallel_jaw"],
                         "planners": ["antipodal"], "grasps_per_object": grasps, "protocol": protocol})


def throughput(config, jobs: int) -> None:
    from manigrasp.bench.label import export_dataset, label

    with tempfile.TemporaryDirectory() as tmp:
        run_dir = Path(tmp) / "run"
        with CpuMeter() as meter:
            summary = label(config, run_dir, jobs=jobs, progress=False)
        cpu = meter.seconds
        start = time.perf_counter()
        sets, _ = export_dataset(run_dir, config)
        export_s = time.perf_counter() - start
    rate = summary.ran / summary.seconds
    print(f"(a) {summary.ran} grasps labelled in {summary.seconds:.1f} s with {jobs} job(s): {rate:.2f} grasps/s, "
          f"{rate / jobs:.2f} grasps/s per core (wall); CPU time {cpu:.1f} s (this process and its workers, polled): "
          f"{summary.ran / cpu:.2f} grasps per CPU-second")
    print(f"    exporter alone: {export_s:.2f} s for {len(sets)} sets ({1e3 * export_s / max(1, summary.ran):.1f} ms "
          "per grasp, native JSON + ACRONYM HDF5)")


class CpuMeter:
    """CPU time (user + system) of this process and every worker process it starts, polled every 0.1 s with
    psutil (a worker's last reading before it exits is kept) [s]."""

    def __init__(self) -> None:
        self._me = psutil.Process()
        self._seen: dict[int, float] = {}
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._poll, daemon=True)

    def _poll(self) -> None:
        while not self._stop.wait(0.1):
            for child in self._me.children(recursive=True):
                try:
                    times = child.cpu_times()
                except psutil.Error:
                    continue
                self._seen[child.pid] = times.user + times.system

    def __enter__(self) -> CpuMeter:
        times = self._me.cpu_times()
        self._start = times.user + times.system
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join()
        times = self._me.cpu_times()
        self.seconds = times.user + times.system - self._start + sum(self._seen.values())


def _is_physics(func: tuple) -> bool:
    filename, _, name = func
    return filename == "~" and any(m in name for m in PHYSICS_MODULES)


def _split(profiler: cProfile.Profile) -> tuple[float, float, list]:
    """(total own time, own time in MuJoCo C calls, the non-physics entries by own time) of a profile."""
    stats = pstats.Stats(profiler).stats
    total = sum(entry[2] for entry in stats.values())
    physics = sum(entry[2] for func, entry in stats.items() if _is_physics(func))
    rest = sorted(((entry[2], func) for func, entry in stats.items() if not _is_physics(func)), reverse=True)
    return total, physics, rest


def profile(config, grasps: int) -> None:
    from dataclasses import replace

    from manigrasp.bench.trials import groups
    from manigrasp.bench.worker import plan_group, run_trial, scene_for

    work = [replace(g, n_grasps=grasps) for g in groups(config)]
    for group in work:  # compile the scenes outside the profile
        scene_for(group)
    plain_plan = plain_trials = 0.0  # first without the profiler: CPU time per plan and per trial
    for group in work:
        start = time.process_time()
        plan = plan_group(group)
        plain_plan += time.process_time() - start
        start = time.process_time()
        for index in range(group.n_grasps):
            run_trial(group, index, plan)
        plain_trials += time.process_time() - start
    # CPU-time profilers: on a shared machine a wall-clock profile counts the time spent waiting for a core.
    planning, trials = cProfile.Profile(time.process_time), cProfile.Profile(time.process_time)
    n = 0
    for group in work:
        plan = planning.runcall(plan_group, group)
        for index in range(group.n_grasps):
            trials.runcall(run_trial, group, index, plan)
            n += 1
    print(f"(b) without the profiler, CPU time: {plain_plan / len(work):.2f} s per plan (settle, observe, plan, "
          f"planned metrics), {plain_trials / n:.3f} s per trial")
    (p_total, p_physics, _), (t_total, t_physics, rest) = _split(planning), _split(trials)
    total, physics = p_total + t_total, p_physics + t_physics
    print(f"    profiled (CPU time, cProfile's overhead included) {n} trials of {len(work)} groups: {total:.1f} s; "
          f"inside MuJoCo's C calls {physics:.1f} s = {physics / total:.0%}, outside physics {1 - physics / total:.0%}")
    print(f"    planning (settle, observe, plan, planned metrics): {p_total:.1f} s, {p_physics / p_total:.0%} physics")
    print(f"    trials (protocol runs): {t_total:.1f} s = {t_total / n:.2f} s each, {t_physics / t_total:.0%} physics;"
          " largest non-physics functions in the trials (own time):")
    for own, (filename, line, name) in rest[:8]:
        where = f"{Path(filename).name}:{line}" if filename != "~" else "builtin"
        print(f"    {own:7.2f} s  {own / t_total:5.1%}  {name} ({where})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--grasps", type=int, default=20, help="candidates per object for (a)")
    parser.add_argument("--jobs", type=int, default=1, help="worker processes for (a)")
    parser.add_argument("--protocol", default="standard", help="trial protocol (default standard)")
    parser.add_argument("--profile-grasps", type=int, default=5, help="candidates per object for (b); 0: skip")
    args = parser.parse_args()
    from manigrasp.objects import catalog

    config = quick_config(args.grasps, args.protocol)
    catalog.build_many([e.source() for e in config.objects], jobs=1)
    throughput(config, max(1, args.jobs))
    if args.profile_grasps > 0:
        profile(quick_config(args.profile_grasps, args.protocol), args.profile_grasps)


if __name__ == "__main__":
    main()
