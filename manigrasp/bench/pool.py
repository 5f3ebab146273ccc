"""Worker processes with hard wall-clock budgets: a task that overruns, or whose worker dies, is reported
and its worker replaced, so one hanging or crashing planner or trial never stops a run.

Each worker runs one task at a time and tells the pool when the budgeted part starts
(`manigrasp.bench.worker.timed_start`); before that (building the scene, loading the object) a task
has `setup_s`. A worker that overruns is killed (SIGKILL); one that dies (os._exit, a segfault) is
noticed by its process sentinel. Workers end with the main process: on Linux the kernel sends them
SIGKILL when it dies (even by kill -9), elsewhere they notice within a second that their parent is gone.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
import time
from collections import deque
from collections.abc import Callable, Iterator
from dataclasses import dataclass, replace
from multiprocessing import get_context
from multiprocessing.connection import Connection, wait
from typing import Self

DEFAULT_SETUP_S = 600.0
"""Budget of a task's part before `timed_start` (scene compile, object load) [s]."""


@dataclass(frozen=True)
class Task:
    """One call to run in a worker: `fn(*args)`, whose budgeted part may last `budget_s` [s]."""

    tag: object
    fn: Callable
    args: tuple
    budget_s: float


@dataclass(frozen=True)
class Outcome:
    """How a task ended: "done" (`value` is its return value), "error" (it raised: `detail`),
    "timeout" (it overran its budget and its worker was killed) or "died" (its worker died);
    `started`: whether its budgeted part had begun (`timed_start`); `killed`: it died of SIGKILL, which the pool
    sends only to a worker that overran (a "timeout"), so something outside killed it (the OOM killer, a person).
    """

    task: Task
    kind: str
    value: object = None
    detail: str = ""
    started: bool = False
    killed: bool = False


def _serve(conn: Connection, parent: int) -> None:  # pragma: no cover - runs in the worker process
    """A worker's loop: receive a task, run it, send back its outcome; end with the parent.

    Ctrl-C is the main process's to handle (it ends the workers): a worker ignores SIGINT, so an
    interrupted run never files a trial as failed.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _die_with_parent(parent)
    from manigrasp.bench import worker

    worker._ON_TIMED_START.append(lambda: conn.send(("start", None)))
    while True:
        try:
            message = conn.recv()
        except (EOFError, OSError):
            return
        if message is None:
            return
        fn, args = message
        try:
            value = fn(*args)
        except BaseException as exc:  # noqa: BLE001 - reported to the main process, which records it
            conn.send(("error", worker.fault_detail(exc)))
            continue
        try:
            conn.send(("done", value))
        except Exception as exc:  # an unpicklable result
            conn.send(("error", worker.fault_detail(exc)))


def _die_with_parent(parent: int) -> None:  # pragma: no cover - runs in the worker process
    if sys.platform.startswith("linux"):
        import ctypes

        try:
            ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
        except (OSError, AttributeError):
            pass
    if os.getppid() != parent:
        os._exit(1)

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(1.0)
        os._exit(1)

    threading.Thread(target=watch, daemon=True).start()


class _Worker:
    def __init__(self, context) -> None:
        self.conn, child = context.Pipe()
        self.process = context.Process(target=_serve, args=(child, os.getpid()), daemon=True)
        self.process.start()
        child.close()
        self.task: Task | None = None
        self.deadline = 0.0
        self.started = False

    def give(self, task: Task, setup_s: float) -> None:
        self.task, self.deadline, self.started = task, time.monotonic() + setup_s + task.budget_s, False
        self.conn.send((task.fn, task.args))

    def kill(self) -> None:
        if self.process.is_alive():
            self.process.kill()
        self.process.join(5.0)
        self.conn.close()


class _Queued:
    """What both pools share: the queue of tasks waiting for a slot, and closing on exit."""

    def __init__(self) -> None:
        self._queue: deque[Task] = deque()

    def submit(self, task: Task, first: bool = False) -> None:
        """Queue `task` (at the front with `first`)."""
        if first:
            self._queue.appendleft(task)
        else:
            self._queue.append(task)

    def close(self) -> None:
        raise NotImplementedError

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class Pool(_Queued):
    """`jobs` worker processes (spawned) running `Task`s under their budgets.

    Args:
        jobs: number of worker processes.
        setup_s: budget of a task's part before it calls `timed_start` [s].
    """

    def __init__(self, jobs: int, setup_s: float = DEFAULT_SETUP_S) -> None:
        super().__init__()
        self._context = get_context("spawn")
        self._jobs = max(1, jobs)
        self._setup_s = setup_s
        self._workers: list[_Worker] = []

    def outcomes(self) -> Iterator[Outcome]:
        """Run the queued tasks (and any submitted meanwhile), yielding each one's `Outcome` as it ends."""
        while self._queue or any(w.task for w in self._workers):
            self._dispatch()
            busy = [w for w in self._workers if w.task is not None]
            timeout = max(0.0, min(w.deadline for w in busy) - time.monotonic())
            ready = wait([w.conn for w in busy] + [w.process.sentinel for w in busy], timeout=min(timeout, 1.0))
            for w in busy:
                outcome = self._check(w, ready)
                if outcome is not None:
                    yield outcome

    def _dispatch(self) -> None:
        self._workers = [w for w in self._workers if w.process.is_alive() or w.task is not None]
        while self._queue and len(self._workers) < self._jobs:
            self._workers.append(_Worker(self._context))
        for w in self._workers:
            if w.task is None and self._queue:
                w.give(self._queue.popleft(), self._setup_s)

    def _check(self, w: _Worker, ready: list) -> Outcome | None:
        task = w.task
        assert task is not None
        if w.conn in ready:
            try:
                kind, value = w.conn.recv()
            except (EOFError, OSError):
                return self._replace(w, _died(task, w))
            if kind == "start":
                w.deadline, w.started = time.monotonic() + task.budget_s, True
                return None
            w.task = None
            return Outcome(task, "done", value) if kind == "done" else Outcome(task, "error", detail=str(value))
        if w.process.sentinel in ready or not w.process.is_alive():
            return self._replace(w, _died(task, w))
        if time.monotonic() > w.deadline:
            return self._replace(w, Outcome(task, "timeout", detail=f"overran its {task.budget_s:g} s budget; "
                                                                     "its worker process was ended"))
        return None

    def _replace(self, w: _Worker, outcome: Outcome) -> Outcome:
        outcome = replace(outcome, started=w.started)
        w.kill()
        w.task = None
        self._workers.remove(w)
        return outcome

    def close(self) -> None:
        """End every worker (idle ones are asked to stop, busy ones are killed)."""
        for w in self._workers:
            if w.task is None and w.process.is_alive():
                try:
                    w.conn.send(None)
                except OSError:
                    pass
                w.process.join(2.0)
            w.kill()
        self._workers = []


def _died(task: Task, w: _Worker) -> Outcome:
    """The outcome of a task whose worker died (`Outcome.killed` if by SIGKILL)."""
    detail = _death(w)
    return Outcome(task, "died", detail=detail, killed=w.process.exitcode == -signal.SIGKILL)


def _death(w: _Worker) -> str:
    w.process.join(2.0)
    code = w.process.exitcode
    if code is not None and code < 0:
        try:
            return f"its worker process died of signal {signal.Signals(-code).name}"
        except ValueError:
            return f"its worker process died of signal {-code}"
    return f"its worker process exited with code {code} before finishing"


@dataclass
class _RayRun:
    """A task running on Ray: its clock key, its deadline, whether it called `timed_start`."""

    task: Task
    key: int
    deadline: float
    started: bool = False


class RayPool(_Queued):
    """The `Pool` interface on a Ray cluster: the same `Task`s, budgets and `Outcome`s.

    At most as many tasks run as the cluster has CPUs (the rest wait here, so a task's clock never runs while
    it queues). A task's budget starts when it calls `timed_start` (reported through a small clock actor and
    seen by the driver within `POLL_S`), before that it has `setup_s`; a task that overruns is cancelled
    with ``ray.cancel(force=True)`` (its worker process is killed) and reported as "timeout". A task whose
    worker dies (a segfault, os._exit) is "died"; tasks are never retried.

    Args:
        ray: the imported, initialised `ray` module.
        slots: tasks run at once (default: the cluster's CPUs).
        setup_s: budget of a task's part before `timed_start` [s].
    """

    POLL_S = 0.5

    def __init__(self, ray, slots: int | None = None, setup_s: float = DEFAULT_SETUP_S) -> None:  # noqa: ANN001
        super().__init__()
        self._ray = ray
        self._slots = max(1, slots or int(ray.cluster_resources().get("CPU", 1)))
        self._setup_s = setup_s
        self._running: dict[object, _RayRun] = {}  # by ObjectRef
        self._clock = ray.remote(num_cpus=0)(_Clock).remote()
        self._call = ray.remote(max_retries=0)(_ray_call)
        self._keys = 0

    def outcomes(self) -> Iterator[Outcome]:
        """Run the queued tasks (and any submitted meanwhile), yielding each one's `Outcome` as it ends."""
        ray = self._ray
        while self._queue or self._running:
            while self._queue and len(self._running) < self._slots:
                task = self._queue.popleft()
                self._keys += 1
                ref = self._call.remote(self._clock, self._keys, task.fn, *task.args)
                self._running[ref] = _RayRun(task, self._keys, time.monotonic() + self._setup_s + task.budget_s)
            nearest = min(run.deadline for run in self._running.values()) - time.monotonic()
            ready, _ = ray.wait(list(self._running), num_returns=1, timeout=max(0.0, min(nearest, self.POLL_S)))
            started = set(ray.get(self._clock.take.remote()))
            now = time.monotonic()
            for run in self._running.values():
                if run.key in started and not run.started:
                    run.deadline, run.started = now + run.task.budget_s, True
            for ref in ready:
                run = self._running.pop(ref)
                try:
                    yield Outcome(run.task, "done", ray.get(ref), started=run.started)
                except ray.exceptions.RayTaskError as exc:  # the task raised
                    yield Outcome(run.task, "error", detail=_ray_reason(exc), started=run.started)
                except ray.exceptions.RayError as exc:  # its worker died (of memory or its node: killed from outside)
                    outside = tuple(getattr(ray.exceptions, name) for name in ("OutOfMemoryError", "NodeDiedError")
                                    if hasattr(ray.exceptions, name))
                    yield Outcome(run.task, "died", detail=f"its Ray task failed: {_ray_reason(exc)}",
                                  started=run.started, killed=isinstance(exc, outside))
            for ref in [r for r, run in self._running.items() if now > run.deadline]:
                run = self._running.pop(ref)
                ray.cancel(ref, force=True)
                yield Outcome(run.task, "timeout", detail=f"overran its {run.task.budget_s:g} s budget; its Ray task "
                                                          "was cancelled (worker process ended)", started=run.started)

    def close(self) -> None:
        """Cancel what still runs."""
        for ref in self._running:
            self._ray.cancel(ref, force=True)
        self._running.clear()
        self._ray.kill(self._clock)


class _Clock:
    """A Ray actor collecting which tasks have called `timed_start` since the driver last asked."""

    def __init__(self) -> None:
        self.started: list[int] = []

    def start(self, key: int) -> None:
        self.started.append(key)

    def take(self) -> list[int]:
        out, self.started = self.started, []
        return out


def _ray_call(clock, key: int, fn: Callable, *args: object) -> object:  # noqa: ANN001 - runs in a Ray worker
    """`fn(*args)` in a Ray worker, telling `clock` when its budgeted part starts."""
    import ray

    from manigrasp.bench import worker

    def started() -> None:  # waits for the clock, so a task that crashes right after still counts as started
        ray.get(clock.start.remote(key))

    worker._ON_TIMED_START.append(started)
    try:
        return fn(*args)
    finally:
        worker._ON_TIMED_START.remove(started)


def _ray_reason(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {' '.join(str(exc).split())}"[:700]
