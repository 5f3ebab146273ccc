"""Rigid vs compliant pads, trial for trial in one process: trials per second and what each trial costs.

Each group of the config (default `quick`) is run twice, once with `scene.pads=rigid` and once with
`scene.pads=compliant`: both are planned, then their trials alternate (rigid trial i, compliant trial i, ...),
so a machine whose load drifts (a shared one) slows both modes alike. Printed per group: the seconds per trial
of each mode (the trial only: approach, close, lift, perturbations and simulated metrics, as the worker runs
it) and their successes; then, over the whole config, trials per second of each mode with and without
planning, and the ratio compliant / rigid. Planning is each mode's own `worker.plan_group` (its scene's build,
the settling, the planner); the object's asset, which both modes share, is built before either clock starts,
and one untimed plan first takes the process's one-time costs (before, the first mode to plan paid both
alone). In this process: no worker pool, no time budgets. Deterministic results for a seed; the timings are
what this machine gave. Then the ratio of this thread's CPU time per simulated trial (`time.thread_time`),
and per trial with planning: on a machine shared with other jobs, wall time swells with their load and CPU
time much less. Then the same CPU time split per mode: inside `mj_step` per simulated step (MuJoCo's physics; each call
timed, without --profile no timer callback slows it) and outside it per trial (control, checks,
simulated-contact metrics in Python), and of the outside the simulated-contact metrics alone
(`protocol.metrics.contact_metrics`: the Ferrari-Canny epsilon's Qhull hull and the smallest friction for
closure, over the grip's contacts: more contacts with compliant pads, so a larger hull).

    .venv/bin/python benchmarks/bench_pad_speed.py                       # quick: 200 trials per mode
    .venv/bin/python benchmarks/bench_pad_speed.py --objects 004_sugar_box --grasps 5
    .venv/bin/python benchmarks/bench_pad_speed.py --profile     # + where a step's time goes, per mode

With --profile, MuJoCo's own timers (`mjData.timer`, read after every `mj_step` of the trials) are summed
per mode and printed as microseconds per step: the whole step, collision detection (of it: the
narrowphase, the pairwise geometry tests) and the constraint solver, with the contacts and constraint
rows per step; then each mode's seconds per trial inside `mj_step` and outside it (control, checks,
simulated metrics). The timers need a clock callback (`mujoco.set_mjcb_time`), a Python call for each
timed section (32 per step, in either mode), which slows every step, about twice over on a shared machine:
trials/s of a --profile run are not the speed figures; the split between sections is what it is for.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import time
from pathlib import Path

import mujoco

os.environ.setdefault("OMP_NUM_THREADS", "1")

from manigrasp.bench import worker  # noqa: E402
from manigrasp.bench.config import load_config  # noqa: E402
from manigrasp.bench.trials import groups  # noqa: E402
from manigrasp.paths import configs_dir  # noqa: E402
from manigrasp.protocol import metrics  # noqa: E402
from manigrasp.protocol.result import Status  # noqa: E402

MODES = ("rigid", "compliant")
# --profile: MuJoCo timer sections printed per step (collision includes narrowphase)
SECTIONS = {"step": mujoco.mjtTimer.mjTIMER_STEP, "collision": mujoco.mjtTimer.mjTIMER_POS_COLLISION,
            "narrowphase": mujoco.mjtTimer.mjTIMER_COL_NARROW, "solver": mujoco.mjtTimer.mjTIMER_CONSTRAINT}


class StepProfile:
    """MuJoCo's timers summed over every `mj_step` the trials make while `active` (the mode being timed; None
    between trials).

    `mujoco.mj_step` is wrapped for the process. The timers accumulate from a data's last reset, so each
    step adds the growth since the previous step of the same data (`end_trial` forgets the trial's data).
    """

    def __init__(self) -> None:
        self.totals = {m: dict.fromkeys(SECTIONS, 0.0) for m in MODES}
        self.steps = dict.fromkeys(MODES, 0)
        self.contacts = dict.fromkeys(MODES, 0)
        self.rows = dict.fromkeys(MODES, 0)
        self.wall = dict.fromkeys(MODES, 0.0)  # [s] inside mj_step
        self.active: str | None = None
        self._last: dict[int, tuple[mujoco.MjData, dict[str, float]]] = {}
        self._step = mujoco.mj_step
        mujoco.set_mjcb_time(time.perf_counter)
        mujoco.mj_step = self.step

    def step(self, model: mujoco.MjModel, data: mujoco.MjData, nstep: int = 1) -> None:
        if self.active is None:  # planning's settling, between trials: not counted
            self._step(model, data, nstep=nstep)
            return
        start = time.perf_counter()
        self._step(model, data, nstep=nstep)
        self.wall[self.active] += time.perf_counter() - start
        last = self._last.get(id(data), (data, dict.fromkeys(SECTIONS, 0.0)))[1]
        now = {key: float(data.timer[t].duration) for key, t in SECTIONS.items()}
        totals = self.totals[self.active]
        for key, value in now.items():
            totals[key] += value - last[key] if value >= last[key] else value  # a reset zeroes the timers
        self._last[id(data)] = (data, now)
        self.steps[self.active] += nstep
        self.contacts[self.active] += data.ncon * nstep
        self.rows[self.active] += data.nefc * nstep

    def end_trial(self) -> None:
        self._last.clear()
        self.active = None

    def report(self, trial_s: dict[str, float], trials: dict[str, int]) -> None:
        print("\n# --profile: microseconds per mj_step (MuJoCo timers; the clock callback slows each step)")
        print(f"{'mode':10s} {'steps':>8s} " + " ".join(f"{k:>12s}" for k in SECTIONS)
              + f" {'other':>8s} {'contacts':>9s} {'rows':>6s}")
        for m in MODES:
            n = max(1, self.steps[m])
            us = {k: v / n * 1e6 for k, v in self.totals[m].items()}
            print(f"{m:10s} {self.steps[m]:8d} " + " ".join(f"{us[k]:12.1f}" for k in SECTIONS)
                  + f" {us['step'] - us['collision'] - us['solver']:8.1f} {self.contacts[m] / n:9.1f}"
                  f" {self.rows[m] / n:6.1f}")
        for m in MODES:
            print(f"{m:10s} s/trial {trial_s[m] / trials[m]:.3f}: in mj_step {self.wall[m] / trials[m]:.3f}, "
                  f"outside (control, checks, simulated metrics) {(trial_s[m] - self.wall[m]) / trials[m]:.3f}")


class MetricsClock:
    """This thread's CPU time inside `protocol.metrics.contact_metrics` (the simulated-contact metrics), per
    mode (`active`; None: not counted). The module function is wrapped for the process (its callers in
    `manigrasp.protocol.metrics` look it up there at each call)."""

    def __init__(self) -> None:
        self.cpu = dict.fromkeys(MODES, 0.0)  # [s]
        self.active: str | None = None
        self._metrics = metrics.contact_metrics
        metrics.contact_metrics = self.metrics

    def metrics(self, *args, **kwargs):  # noqa: ANN002, ANN003, ANN201
        start = time.thread_time()
        try:
            return self._metrics(*args, **kwargs)
        finally:
            if self.active is not None:
                self.cpu[self.active] += time.thread_time() - start


class StepClock:
    """This thread's CPU time inside `mujoco.mj_step` and the steps it made, per mode (`active`; None, as while
    planning: not counted).

    `mujoco.mj_step` is wrapped for the process (the trials call it with `nstep` chunks: one reading of the
    clock per call, well under a microsecond per step). Under `--profile` it times `StepProfile`'s wrapper,
    timer callbacks included: the per-step figures of a --profile run are slower than a plain run's.
    """

    def __init__(self) -> None:
        self.cpu = dict.fromkeys(MODES, 0.0)  # [s] inside mj_step
        self.steps = dict.fromkeys(MODES, 0)
        self.active: str | None = None
        self._step = mujoco.mj_step
        mujoco.mj_step = self.step

    def step(self, model: mujoco.MjModel, data: mujoco.MjData, nstep: int = 1) -> None:
        if self.active is None:
            self._step(model, data, nstep=nstep)
            return
        start = time.thread_time()
        self._step(model, data, nstep=nstep)
        self.cpu[self.active] += time.thread_time() - start
        self.steps[self.active] += nstep

    def report(self, cpu_s: dict[str, float], trials: dict[str, int], metrics_s: dict[str, float]) -> None:
        us = {m: self.cpu[m] / max(1, self.steps[m]) * 1e6 for m in MODES}
        outside = {m: (cpu_s[m] - self.cpu[m]) / trials[m] for m in MODES}
        contact = {m: metrics_s[m] / trials[m] for m in MODES}
        print(f"CPU per simulated step inside mj_step: rigid {us['rigid']:.1f} us, compliant {us['compliant']:.1f} us "
              f"({us['compliant'] / us['rigid']:.2f}x; {self.steps['rigid'] / trials['rigid']:.0f} vs "
              f"{self.steps['compliant'] / trials['compliant']:.0f} steps per trial); outside mj_step per trial: "
              f"rigid {outside['rigid']:.3f} s, compliant {outside['compliant']:.3f} s; of it simulated-contact "
              f"metrics rigid {contact['rigid']:.3f} s, compliant {contact['compliant']:.3f} s")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--config", default="quick", help="shipped config name or YAML path (default quick)")
    parser.add_argument("--objects", nargs="+", default=None, help="objects (default: the config's)")
    parser.add_argument("--planners", nargs="+", default=None, help="planners (default: the config's)")
    parser.add_argument("--grasps", type=int, default=None, help="grasps per object (default: the config's)")
    parser.add_argument("--profile", action="store_true", help="also print where a step's time goes (slower)")
    args = parser.parse_args()
    profile = StepProfile() if args.profile else None
    clock = StepClock()
    metrics_clock = MetricsClock()
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
    cpu_s = {m: 0.0 for m in MODES}
    plan_cpu = {m: 0.0 for m in MODES}  # [s] this thread's CPU time planning
    todo = list(groups(config, path.parent))
    if todo:  # the process's one-time costs (imports, first calls) on an untimed plan, not on the first mode's
        worker.plan_group(todo[0])
        worker._SCENES.clear()  # each mode's timed planning still builds its own scene
    for group in todo:
        pair = {m: dataclasses.replace(group, scene=dataclasses.replace(group.scene, pads=m)) for m in MODES}
        plans, seconds, ok = {}, {m: 0.0 for m in MODES}, {m: 0 for m in MODES}
        worker._asset(group)  # the object's asset serves both modes: built (or loaded) before either's clock
        for mode, g in pair.items():
            start, cpu = time.perf_counter(), time.thread_time()
            plans[mode] = worker.plan_group(g)
            plan_s[mode] += time.perf_counter() - start
            plan_cpu[mode] += time.thread_time() - cpu
        for index in range(group.n_grasps):
            for mode, g in pair.items():
                clock.active = metrics_clock.active = mode
                if profile is not None:
                    profile.active = mode
                start, cpu = time.perf_counter(), time.thread_time()
                _, result = worker.run_trial(g, index, plans[mode])
                seconds[mode] += time.perf_counter() - start
                cpu_s[mode] += time.thread_time() - cpu
                clock.active = metrics_clock.active = None
                if profile is not None:
                    profile.end_trial()
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
    print(f"compliant / rigid CPU time of this thread per simulated trial: {cpu_s['compliant'] / cpu_s['rigid']:.2f}x "
          f"({cpu_s['rigid'] / trials['rigid']:.3f} vs {cpu_s['compliant'] / trials['compliant']:.3f} s; on a shared "
          "machine the steadier figure)")
    print(f"compliant / rigid CPU time of this thread per trial with planning: "
          f"{(cpu_s['compliant'] + plan_cpu['compliant']) / (cpu_s['rigid'] + plan_cpu['rigid']):.2f}x "
          f"({plan_cpu['rigid']:.1f} vs {plan_cpu['compliant']:.1f} s planning)")
    clock.report(cpu_s, trials, metrics_clock.cpu)
    if profile is not None:
        profile.report(trial_s, trials)


if __name__ == "__main__":
    main()
