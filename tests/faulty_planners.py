"""Planners that misbehave, loaded by the harness tests as ``faulty_planners:NAME``."""

from __future__ import annotations

import numpy as np

from manigrasp.planners import GraspCandidate


class Raises:
    """A planner that always raises."""

    name = "raises"
    needs = "mesh"

    def plan(self, observation, hand, n, rng):
        raise RuntimeError("planner exploded")


class ReturnsNaN:
    """A planner whose only candidate has a NaN pose."""

    name = "returns_nan"
    needs = "mesh"

    def plan(self, observation, hand, n, rng):
        pose = np.eye(4)
        pose[0, 3] = np.nan
        return [GraspCandidate(pose=pose, score=1.0)]


class TopDown:
    """A working planner with a parameter: top-down grasps over the object's origin, `lift` [m] higher."""

    name = "top_down"
    needs = "mesh"

    def __init__(self, lift: float = 0.0) -> None:
        self.lift = lift

    def plan(self, observation, hand, n, rng):
        pose = np.diag([1.0, -1.0, -1.0, 1.0])  # TCP z (approach) pointing down
        pose[:3, 3] = observation.object_pose[:3, 3] + [0.0, 0.0, self.lift]
        return [GraspCandidate(pose=pose.copy(), score=1.0 - 0.01 * i) for i in range(n)]


class Sleeps:
    """A planner that never returns."""

    name = "sleeps"
    needs = "mesh"

    def plan(self, observation, hand, n, rng):
        import time

        while True:
            time.sleep(1.0)


class Exits:
    """A planner that ends its process without a word (os._exit)."""

    needs = "mesh"

    def plan(self, observation, hand, n, rng):
        import os

        os._exit(3)


class Segfaults:
    """A planner that crashes its process (SIGSEGV)."""

    needs = "mesh"

    def plan(self, observation, hand, n, rng):
        import ctypes

        ctypes.string_at(0)


class CallsSysExit:
    """A planner that raises SystemExit(5)."""

    needs = "mesh"

    def plan(self, observation, hand, n, rng):
        raise SystemExit(5)


class WideWidth:
    """A planner whose candidate has width="wide"."""

    needs = "mesh"

    def plan(self, observation, hand, n, rng):
        return [GraspCandidate(pose=np.eye(4), score=1.0, width="wide")]


class NoPreshape:
    """A planner whose candidate has preshape=None."""

    needs = "mesh"

    def plan(self, observation, hand, n, rng):
        return [GraspCandidate(pose=np.eye(4), score=1.0, preshape=None)]


class FactoryRaises:
    """A planner whose constructor raises."""

    needs = "mesh"

    def __init__(self) -> None:
        raise RuntimeError("cannot build me")

    def plan(self, observation, hand, n, rng):  # pragma: no cover - never built
        return []


def raising_protocol(**params):
    """A protocol (factory function) whose trials raise inside the harness."""
    from manigrasp.protocol.lift import LiftProtocol

    class Raising(LiftProtocol):
        def run(self, *args, **kwargs):
            raise RuntimeError("protocol bug")

    return Raising()


def sleeping_protocol(**params):
    """A protocol (factory function) whose trials never end."""
    from manigrasp.protocol.lift import LiftProtocol

    class Sleeping(LiftProtocol):
        def run(self, *args, **kwargs):
            import time

            while True:
                time.sleep(1.0)

    return Sleeping()


def raising_hand():
    """A hand factory that raises."""
    raise RuntimeError("no hand today")


class RaisesCancelled:
    """A planner that raises asyncio.CancelledError (a BaseException, not an Exception)."""

    needs = "mesh"

    def plan(self, observation, hand, n, rng):
        import asyncio

        raise asyncio.CancelledError("cancelled inside the planner")


class UnreadableError:
    """A planner whose exception cannot be turned into text (its __str__ raises)."""

    needs = "mesh"

    def plan(self, observation, hand, n, rng):
        class Unreadable(RuntimeError):
            def __str__(self):
                raise ValueError("no text")

        raise Unreadable()


class LocalSubclass:
    """A planner whose candidates are of a GraspCandidate subclass defined in `plan` (it cannot be pickled)."""

    needs = "mesh"

    def plan(self, observation, hand, n, rng):
        from manigrasp.planners.random_planner import RandomPlanner

        class Mine(GraspCandidate):
            pass

        import dataclasses

        return [Mine(**{f.name: getattr(c, f.name) for f in dataclasses.fields(c) if f.init})
                for c in RandomPlanner().plan(observation, hand, n, rng)]


class KilledFromOutside:
    """A planner whose worker process receives SIGKILL while it plans (as from the OOM killer)."""

    needs = "mesh"

    def plan(self, observation, hand, n, rng):
        import os
        import signal

        os.kill(os.getpid(), signal.SIGKILL)
