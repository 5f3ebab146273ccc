"""Running a benchmark: validate, enumerate, plan, run trials in parallel, store as they finish.

Executors: "local" (a process pool on this machine; inline when jobs = 1)
and "ray" (the same tasks on a Ray cluster, or a local Ray instance when no
address is given; needs the optional `ray` extra). Planning is one task per
group, each trial one task, so a killed run loses at most the trials that
were running; re-running the same command resumes from the store.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Iterator
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass
from multiprocessing import get_context
from pathlib import Path

from manigrasp.bench import rundir
from manigrasp.bench.config import BenchConfig
from manigrasp.bench.store import ResultsStore, TrialKey
from manigrasp.bench.trials import Group, groups
from manigrasp.bench.worker import Plan, plan_group, run_trial
from manigrasp.errors import ConfigError
from manigrasp.protocol.result import TrialResult
from manigrasp.record.policy import RecordSettings

EXECUTORS = ("local", "ray")


@dataclass(frozen=True)
class RunSummary:
    """What a `run_benchmark` call did."""

    run_dir: Path
    total: int
    already_done: int
    ran: int
    successes: int
    seconds: float


def validate(config: BenchConfig, base: Path | None = None) -> list[Group]:
    """Resolve every name in `config` (objects, hands, planners, protocol): errors before any trial."""
    from manigrasp import hands, planners
    from manigrasp.protocol import PROTOCOLS

    found = groups(config, base)
    for hand in config.hands:
        hands.load(hand)
    for planner in config.planners:
        planners.load(planner.name, **dict(planner.params))
    PROTOCOLS.load(config.protocol.name, **dict(config.protocol.params))
    return found


def run_benchmark(
    config: BenchConfig,
    run_dir: Path,
    jobs: int = 1,
    executor: str = "local",
    address: str | None = None,
    base: Path | None = None,
    progress: bool = True,
    on_result: Callable[[TrialKey, TrialResult], None] | None = None,
    record: str = "none",
) -> RunSummary:
    """Run (or resume) the benchmark of `config` into `run_dir`.

    `record` is a recording policy ("none", "failures", "successes", "all" or N: the first N trials of
    each group): those trials are written to ``run_dir/recordings/<trial>.rrd``. Recording never
    changes a result.
    """
    if executor not in EXECUTORS:
        raise ConfigError(f"unknown executor {executor!r}; available: {', '.join(EXECUTORS)}")
    start = time.perf_counter()
    all_groups = validate(config, base)
    run_dir = Path(run_dir)
    rundir.prepare(run_dir, config)
    settings = RecordSettings.for_run(run_dir, record)
    _prebuild_objects(all_groups, jobs)
    store = ResultsStore(run_dir / "results.sqlite")
    done = store.done_ids()
    todo = {id(g): [i for i in range(g.n_grasps) if g.key(i).trial_id not in done] for g in all_groups}
    pending = [g for g in all_groups if todo[id(g)]]
    total = sum(g.n_grasps for g in all_groups)
    already = total - sum(len(v) for v in todo.values())
    bar = _progress_bar(total, already, progress)
    ran = successes = 0
    try:
        tasks = _iter_ray if executor == "ray" else _iter_local
        for key, result in tasks(pending, todo, jobs, address, settings):
            if store.add(key, result):
                ran += 1
                successes += result.success
            if on_result is not None:
                on_result(key, result)
            bar.update(1)
            bar.set_postfix(success=f"{successes}/{ran}", refresh=False)
    finally:
        bar.close()
        store.close()
    return RunSummary(run_dir, total, already, ran, successes, time.perf_counter() - start)


def _prebuild_objects(all_groups: list[Group], jobs: int) -> None:
    """Build (or load from cache) every object once, in parallel, before workers need them."""
    from manigrasp.objects import catalog

    sources = list({g.object_source.name: g.object_source for g in all_groups}.values())
    failed = [o for o in catalog.build_many(sources, jobs=jobs) if o.error]
    if failed:
        raise ConfigError("; ".join(f"object {o.name}: {o.error}" for o in failed))


def _progress_bar(total: int, initial: int, enabled: bool):
    from tqdm import tqdm

    return tqdm(total=total, initial=initial, unit="trial", desc="trials", file=sys.stderr,
                disable=not enabled, dynamic_ncols=True, smoothing=0.1)


def _iter_local(pending: list[Group], todo: dict, jobs: int, address: str | None, settings
                ) -> Iterator[tuple[TrialKey, TrialResult]]:
    if jobs <= 1:
        for group in pending:
            plan = plan_group(group)
            for index in todo[id(group)]:
                yield run_trial(group, index, plan, settings)
        return
    with ProcessPoolExecutor(max_workers=jobs, mp_context=get_context("spawn")) as pool:
        plans: dict[Future, Group] = {pool.submit(plan_group, g): g for g in pending}
        trials: set[Future] = set()
        while plans or trials:
            finished, _ = wait(set(plans) | trials, return_when=FIRST_COMPLETED)
            for future in finished:
                if future in plans:
                    group = plans.pop(future)
                    plan: Plan = future.result()
                    trials |= {pool.submit(run_trial, group, i, plan, settings) for i in todo[id(group)]}
                else:
                    trials.discard(future)
                    yield future.result()


def _iter_ray(pending: list[Group], todo: dict, jobs: int, address: str | None, settings
              ) -> Iterator[tuple[TrialKey, TrialResult]]:
    try:
        import ray
    except ImportError as exc:
        raise ConfigError("the ray executor needs the optional extra: pip install 'manigrasp[ray]'") from exc
    if not ray.is_initialized():
        ray.init(address=address, num_cpus=None if address else jobs, include_dashboard=False,
                 log_to_driver=False, ignore_reinit_error=True)
    remote_plan = ray.remote(plan_group)
    remote_trial = ray.remote(run_trial)
    plans = {remote_plan.remote(g): g for g in pending}
    trials: list = []
    while plans or trials:
        ready, _ = ray.wait(list(plans) + trials, num_returns=1)
        ref = ready[0]
        if ref in plans:
            group = plans.pop(ref)
            plan = ray.get(ref)
            trials += [remote_trial.remote(group, i, plan, settings) for i in todo[id(group)]]
        else:
            trials.remove(ref)
            yield ray.get(ref)

