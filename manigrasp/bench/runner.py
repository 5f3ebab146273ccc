"""Running a benchmark: validate, enumerate, plan, run trials in parallel, store as they finish.

Executors: "local" (worker processes on this machine, `manigrasp.bench.pool`:
planning and trials have hard wall-clock budgets, and a worker that hangs or
dies is replaced with its task recorded) and "ray" (the same tasks on a Ray
cluster, or a local Ray instance when no address is given; needs the optional
`ray` extra; the same budgets, enforced with `ray.cancel(force=True)`, and a task
whose worker dies is recorded: `manigrasp.bench.pool.RayPool`). Optional extras
the config needs are checked first (`manigrasp.bench.extras`).
Planning is one task per group, each trial one task, so a killed run loses at
most the trials that were running; re-running the same command resumes from
the store. The run directory is locked while a run uses it.
"""

from __future__ import annotations

import os
import sqlite3
import sys
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, replace
from pathlib import Path

from manigrasp.bench import rundir
from manigrasp.bench.config import BenchConfig
from manigrasp.bench.extras import install_hint
from manigrasp.bench.pool import Outcome, Pool, Task
from manigrasp.bench.store import ResultsStore, TrialKey
from manigrasp.bench.trials import Group, groups
from manigrasp.bench.worker import Plan, plan_group, run_trial, with_source
from manigrasp.errors import ConfigError, ManigraspError
from manigrasp.protocol.result import Status, TrialResult
from manigrasp.record.policy import RecordPolicy, RecordSettings, recording_problem, trial_file_name
from manigrasp.runfiles import RECORDINGS_DIR, STORE_NAME

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
    recorded: tuple = ()
    record_skipped: tuple = ()

    @property
    def record_note(self) -> str | None:
        """One line on the stored trials recorded after the run (`--record` on stored trials), or None."""
        if not self.recorded and not self.record_skipped:
            return None
        differ = sum(not r.same_status for r in self.recorded)
        parts = [f"recorded {len(self.recorded)} stored trial(s) by re-simulating their stored grasp and seed"
                 f" into {self.run_dir / 'recordings'}"]
        if differ:
            parts.append(f"{differ} replayed with another status than stored (see `manigrasp replay`)")
        if self.record_skipped:
            reasons: dict[str, int] = {}
            for _, why in self.record_skipped:
                key = "already recorded" if why.startswith("already recorded") else why
                reasons[key] = reasons.get(key, 0) + 1
            parts.append(f"{len(self.record_skipped)} not recorded (" +
                         ", ".join(f"{n}: {why}" for why, n in reasons.items()) + ")")
        return "; ".join(parts)


def validate(config: BenchConfig, base: Path | None = None) -> list[Group]:
    """Resolve every name in `config` (objects, hands, planners, protocol): errors before any trial.

    A ``module:attribute`` entry must be of the right kind (a planner class or object, a `Hand` or a
    function returning one, a `Protocol` class or factory function) before it is called.
    """
    from manigrasp import hands, planners
    from manigrasp.errors import PlannerError
    from manigrasp.protocol import PROTOCOLS

    found = groups(config, base)
    kinds = {}
    for hand in config.hands:
        _check_kind(hand, "hand")
        kinds[hand] = _built(f"hand {hand!r}", hands.load, hand).kind
    for planner in config.planners:
        try:
            made = planners.load(planner.name, **dict(planner.params))
        except PlannerError as exc:
            if "building it raised" not in str(exc):  # a planner whose constructor raises is its trials' status
                raise
            continue
        _note_hand_kinds(planner.name, getattr(made, "hand_kinds", None), kinds)
    for protocol in config.protocol_entries:
        _check_kind(protocol.name, "protocol")
        _built(f"protocol {protocol.name!r}", PROTOCOLS.load, protocol.name, **dict(protocol.params))
    return found


def grip_limits(config: BenchConfig) -> dict[str, float]:
    """Each hand's largest grip force [N] (`Hand.max_grip_force`), recorded in run.json (`rundir.start`); the
    hands were loaded by `validate` (built-in hands are cached)."""
    from manigrasp import hands

    return {hand: float(hands.load(hand).max_grip_force) for hand in config.hands}


def _note_hand_kinds(planner: str, planned: tuple[str, ...] | None, kinds: dict[str, str]) -> None:
    """Tell, before any trial, which hands of the run a planner cannot plan for (its `hand_kinds`): their
    trials are run and recorded as `planner_error` (a config may mix hand kinds on purpose, so this is a note)."""
    other = [f"{hand} ({kind})" for hand, kind in kinds.items() if planned and kind not in planned]
    if other:
        print(f"manigrasp: note: planner {planner!r} plans for {' and '.join(planned)} hands only: its trials with "
              f"{', '.join(other)} will end planner_error", file=sys.stderr)


def _built(what: str, load: Callable, *args: object, **params: object) -> object:
    """`load(*args, **params)`; a user factory's own exception becomes a one-line `ConfigError`."""
    try:
        return load(*args, **params)
    except ManigraspError:
        raise
    except Exception as exc:
        raise ConfigError(f"{what}: building it raised {type(exc).__name__}: {exc}") from exc


def _check_kind(name: str, kind: str) -> None:
    """Refuse a ``module:attribute`` hand or protocol that is not of its kind, before anything calls it."""
    if ":" not in name:
        return
    import types

    from manigrasp.hands import Hand
    from manigrasp.protocol.base import Protocol
    from manigrasp.registry import import_attribute

    attr = import_attribute(name, kind)
    expected = Hand if kind == "hand" else Protocol
    if isinstance(attr, expected) or (isinstance(attr, type) and issubclass(attr, expected)) \
            or isinstance(attr, types.FunctionType):
        return
    raise ConfigError(f"{kind} {name!r} is a {type(attr).__name__}: only a {expected.__name__}, a {expected.__name__} "
                      "class or a Python function returning one is accepted (it was not called)")


def max_jobs() -> int:
    """The cores this process may use: the cap of `--jobs`."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


def run_benchmark(
    config: BenchConfig,
    run_dir: Path,
    jobs: int = 1,
    executor: str = "local",
    address: str | None = None,
    base: Path | None = None,
    progress: bool = True,
    on_result: Callable[[TrialKey, TrialResult], None] | None = None,
    record: str | RecordPolicy = "none",
    in_process: bool = False,
) -> RunSummary:
    """Run (or resume) the benchmark of `config` into `run_dir`.

    `record` is a recording policy ("none", "failures", "successes", "all" or N: the first N trials of
    each group): those trials are written to ``run_dir/recordings/<trial>.rrd``. Recording never
    changes a result.

    Trials stored before this call are not run again; those of them `record` selects are re-simulated from
    their stored grasp and seed and recorded after the run (`manigrasp.bench.replay.record_trials`; in this
    process, without time budgets), reported in the summary's `recorded`, `record_skipped` and `record_note`.
    A recordings folder that cannot be written (a file named `recordings`) is said on stderr in one line and
    the trials run and are stored all the same: a recording failure never changes a result.

    `in_process` (local executor, one job) plans and runs trials in this process, for profiling: no hard
    time budgets, and a planner that hangs or crashes the process takes the run with it.
    """
    if executor not in EXECUTORS:
        raise ConfigError(f"unknown executor {executor!r}; available: {', '.join(EXECUTORS)}")
    if in_process and (executor != "local" or jobs != 1):
        raise ConfigError("in_process runs the local executor with one job")
    if executor == "local" and jobs > max_jobs():
        print(f"manigrasp: --jobs {jobs} capped at the {max_jobs()} cores of this machine", file=sys.stderr)
        jobs = max_jobs()
    start = time.perf_counter()
    policy = record if isinstance(record, RecordPolicy) else RecordPolicy.parse(record)
    from manigrasp.bench import extras

    extras.check(config, executor)
    all_groups = validate(config, base)
    run_dir = Path(run_dir)
    with rundir.locked(run_dir):
        # Objects are built (their meshes read) after the folder is checked and before run.json is written: a
        # folder of another run is refused before minutes of building, and a broken mesh leaves no run.json
        # (with that mesh's hash) that would refuse the corrected rerun.
        existing = rundir.check(run_dir, config, base)
        named = {g.key(i).trial_id for g in all_groups for i in range(g.n_grasps)}
        if existing is not None and (run_dir / STORE_NAME).exists():
            store, stored = _open_store(run_dir)
            store.close()
            _refuse_unnamed(run_dir, stored, named)
        keys = _prebuild_objects(all_groups, jobs, progress) or {}
        all_groups = [replace(g, object_key=keys.get(g.object_source.name, "")) for g in all_groups]
        meta = rundir.start(run_dir, config, existing, base, grip_limits(config))
        settings = RecordSettings.for_run(run_dir, policy)
        problem = recording_problem(settings)
        if problem:
            print(f"manigrasp: {problem}; the trials run and are stored without recordings", file=sys.stderr)
            settings = None
        store, done = _open_store(run_dir)
        # A trial stored as a harness fault (a bug of manigrasp, or its worker killed from outside: the OOM killer)
        # is no outcome: it runs again, its row replaced by the new result (`ResultsStore.add`).
        faulted = store.fault_ids() & named
        if faulted:
            print(f"manigrasp: {len(faulted)} trial(s) stored as harness_fault run again", file=sys.stderr)
            for trial_id in faulted:  # a recording of the faulted attempt would be listed under the new status
                (run_dir / RECORDINGS_DIR / trial_file_name(trial_id)).unlink(missing_ok=True)
        done = done - faulted
        todo = {id(g): [i for i in range(g.n_grasps) if g.key(i).trial_id not in done] for g in all_groups}
        pending = [g for g in all_groups if todo[id(g)]]
        # A resumed run that stores trials under other code says so, and run.json records it once the first is
        # stored (the report warns of it); a resume that runs nothing (to export or record) mixes nothing.
        other_code = rundir.code_changes(meta) if pending and meta.get("resumed") else []
        if other_code:
            rundir.warn_other_code(run_dir, other_code)
        total = sum(g.n_grasps for g in all_groups)
        already = total - sum(len(v) for v in todo.values())
        bar = _progress_bar(total, already, progress)
        ran = successes = faults = 0
        try:
            tasks = _iter_ray if executor == "ray" else _iter_inline if in_process else _iter_local
            for key, result in tasks(pending, todo, jobs, address, settings):
                if _add(store, key, result, key.trial_id in faulted):
                    ran += 1
                    successes += result.success
                    faults += result.status is Status.HARNESS_FAULT
                    if other_code and ran == 1:
                        rundir.record_other_code(run_dir, meta["resumed"][-1], other_code, ran)
                if on_result is not None:
                    on_result(key, result)
                # Set before the step that draws it; on a resumed run the bar counts the stored trials too, the
                # successes only this session's trials; harness faults apart, as the reports count them.
                bar.set_postfix_str(f"success={successes}/{ran - faults}" + (" this session" if already else "")
                                    + (f", {faults} harness fault(s)" if faults else ""), refresh=False)
                bar.update(1)
        finally:
            bar.close()
            store.close()
            if other_code and ran > 1:
                rundir.record_other_code(run_dir, meta["resumed"][-1], other_code, ran)
        recorded = _record_stored(run_dir, policy, done, base) if settings is not None and done else None
    return RunSummary(run_dir, total, already, ran, successes, time.perf_counter() - start,
                      *((recorded.replays, recorded.skipped) if recorded else ()))


def _record_stored(run_dir: Path, policy: RecordPolicy, done: set[str], base: Path | None):
    """Record the trials stored before this run that `policy` selects, re-simulating each (a `Recorded`)."""
    from manigrasp.bench.replay import record_trials, stored_trials

    stored = stored_trials(run_dir, base)
    chosen = [t for t in sorted(done & set(stored))
              if policy.may_record(stored[t].index) and policy.keeps(stored[t].result.status)]
    what = f"the first {policy.first_n} of each group" if policy.kind == "first" else policy.kind
    if chosen:
        print(f"manigrasp: recording {len(chosen)} stored trial(s) ({what}) by re-simulating them", file=sys.stderr)
    else:
        print(f"manigrasp: --record: none of the {len(done)} trials stored before this run is among {what}; "
              "nothing to record", file=sys.stderr)
    try:
        return record_trials(run_dir, chosen, base)
    except ManigraspError as exc:  # the results stand; only the recordings are missing
        print(f"manigrasp: the stored trials could not be recorded: {exc}", file=sys.stderr)
        return None


def _refuse_unnamed(run_dir: Path, stored: set[str], named: set[str]) -> None:
    """Refuse to resume a run whose store holds trials (`stored` ids) this code does not name for the run's config
    (`named` ids): the code that ran them named a group otherwise (a YCB download's object was its folder's name,
    `025_mug`, before it was `025_mug_ycb`), and resumed the run would hold the same trials under both names."""
    stray = sorted(stored - named)
    if stray:
        raise ConfigError(f"{run_dir} stores {len(stray)} trial(s) that this version does not name for the run's "
                          f"config (e.g. {stray[0]}): the version that ran them named its groups otherwise (a YCB "
                          "download's object is named <folder>_ycb since 4 Dec 2026); resumed, the run would hold "
                          "them twice under two names. Use another --out to start a new run")


def _open_store(run_dir: Path) -> tuple[ResultsStore, set[str]]:
    """The run's store and the ids it holds; `ConfigError` for a file that is not a readable store."""
    try:
        store = ResultsStore(run_dir / STORE_NAME)
        return store, store.done_ids()
    except sqlite3.DatabaseError as exc:
        raise ConfigError(f"{run_dir / 'results.sqlite'} is not a readable results store ({exc}); "
                          "use another --out") from None


def _add(store: ResultsStore, key: TrialKey, result: TrialResult, replace_fault: bool = False) -> bool:
    """Store one trial (replacing its stored harness fault with `replace_fault`); a store that cannot be written (a
    full disk) ends the run with one line."""
    try:
        return store.add(key, result, replace_fault)
    except sqlite3.OperationalError as exc:
        raise ManigraspError(f"cannot store trial {key.trial_id} in {store.path}: {exc}; the trials stored so "
                             "far are kept, and re-running the same command resumes from there") from None


def _prebuild_objects(all_groups: list[Group], jobs: int, progress: bool = False) -> dict[str, str]:
    """Build (or load from cache) every object once, in parallel, before workers need them; with
    `progress`, say which object is being built and how it went (a cold cache builds for minutes). Returns each
    object's hull key (`Group.object_key`: the workers' builds must match it)."""
    from manigrasp.objects import catalog

    sources = list({g.object_source.name: g.object_source for g in all_groups}.values())
    started: set[str] = set()

    def start(source: catalog.ObjectSource) -> None:
        started.add(source.name)
        print(f"object {source.name}: building...", file=sys.stderr, flush=True)

    def done(outcome: catalog.BuildOutcome) -> None:
        if outcome.name in started:  # shipped objects known built say nothing
            print(f"object {catalog.summary(outcome)}", file=sys.stderr, flush=True)

    outcomes = catalog.build_many(sources, jobs=jobs, on_start=start if progress else None, on_done=done)
    failed = [o for o in outcomes if o.error]
    if failed:
        raise ConfigError("; ".join(f"object {o.name}: {o.error}" for o in failed))
    return {o.name: str(o.result.asset.metadata.get("hull_key", "")) for o in outcomes if o.result is not None}


def _progress_bar(total: int, initial: int, enabled: bool):
    from tqdm import tqdm

    return tqdm(total=total, initial=initial, unit="trial", desc="trials", file=sys.stderr,
                disable=not enabled, dynamic_ncols=True, smoothing=0.1)


TRIAL_GRACE_S = 10.0
"""Hard budget of a trial beyond its `trial_timeout_s` (the protocol's own deadline stops it first when it can)."""


def _iter_local(pending: list[Group], todo: dict, jobs: int, address: str | None, settings
                ) -> Iterator[tuple[TrialKey, TrialResult]]:
    """Plan each group, then run its trials, in `jobs` worker processes (`manigrasp.bench.pool`).

    A group whose planner call overruns `trial_timeout_s` is `timeout` for all its trials; a trial that
    overruns its budget by `TRIAL_GRACE_S` is `timeout`; a worker that dies while planning makes its group
    `planner_error` (`harness_fault` if it died before the planner was called), while running a trial that
    trial `harness_fault`; the run goes on.
    """
    with Pool(jobs) as pool:
        yield from _run_tasks(pool, pending, todo, settings)


def _run_tasks(pool, pending: list[Group], todo: dict, settings) -> Iterator[tuple[TrialKey, TrialResult]]:  # noqa: ANN001
    """Plan each group, then run its trials, in `pool` (a `Pool` or a `RayPool`)."""
    for group in pending:
        pool.submit(Task(("plan", group), plan_group, (group,), group.timeout_s))
    for outcome in pool.outcomes():
        kind, group, *index = outcome.task.tag
        if kind == "plan":
            plan = outcome.value if outcome.kind == "done" else _failed_plan(group, outcome)
            for i in reversed(todo[id(group)]):  # trials before further plans: results stream early
                pool.submit(Task(("trial", group, i), run_trial, (group, i, plan, settings),
                                 group.timeout_s + TRIAL_GRACE_S), first=True)
        elif outcome.kind == "done":
            yield outcome.value
        else:
            candidates = outcome.task.args[2].candidates  # the trial's task: run_trial(group, i, plan, settings)
            source = candidates[index[0]].source if index[0] < len(candidates) else ""
            yield group.key(index[0]), _failed_trial(group, index[0], outcome, source)


def _iter_inline(pending: list[Group], todo: dict, jobs: int, address: str | None, settings
                 ) -> Iterator[tuple[TrialKey, TrialResult]]:
    for group in pending:
        plan = plan_group(group)
        for index in todo[id(group)]:
            yield run_trial(group, index, plan, settings)


def _failed_plan(group: Group, outcome: Outcome) -> Plan:
    if outcome.kind == "timeout":
        return Plan.failed(group, Status.TIMEOUT, f"planning {outcome.detail}", group.timeout_s)
    if outcome.kind == "died":  # in the planner's call: the planner's; before it (scene, settling): the harness's
        # (killed from outside, SIGKILL: no outcome of the planner's, a harness fault that a resumed run retries)
        status = Status.PLANNER_ERROR if outcome.started and not outcome.killed else Status.HARNESS_FAULT
        return Plan.failed(group, status, f"while {'planning' if outcome.started else 'preparing to plan'}, "
                                          f"{outcome.detail}")
    return Plan.failed(group, Status.HARNESS_FAULT, f"planning failed: {outcome.detail}")


def _failed_trial(group: Group, index: int, outcome: Outcome, source: str = "") -> TrialResult:
    """The result of a trial whose worker overran its budget or died; its detail begins with the candidate's
    `source` as a finished trial's does (the `file` planner's "file grasp j")."""
    status = Status.TIMEOUT if outcome.kind == "timeout" else Status.HARNESS_FAULT
    return TrialResult(status, detail=with_source(source, f"trial {outcome.detail}")[:800],
                       seed=group.trial_seed(index))


def _iter_ray(pending: list[Group], todo: dict, jobs: int, address: str | None, settings
              ) -> Iterator[tuple[TrialKey, TrialResult]]:
    """`_iter_local` on Ray (`manigrasp.bench.pool.RayPool`): the same tasks, budgets and recorded statuses."""
    try:
        import ray
    except ImportError as exc:
        raise ConfigError(f"the ray executor needs the optional `ray` extra: {install_hint('ray')}") from exc
    from manigrasp.bench.pool import RayPool

    if not ray.is_initialized():
        ray.init(address=address, num_cpus=None if address else jobs, include_dashboard=False,
                 log_to_driver=False, ignore_reinit_error=True)
    with RayPool(ray, slots=None if address else jobs) as pool:
        yield from _run_tasks(pool, pending, todo, settings)

