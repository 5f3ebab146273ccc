"""What a protocol is and the registry of protocols (the grasp it executes: `manigrasp.protocol.grasp`).

A protocol runs one grasp in a compiled `manigrasp.sim.Scene` and returns one
`TrialResult`; it never raises for a fault of the trial (a NaN pose, a
diverging simulation, a blown time budget): that is the trial's status.

    >>> protocol = PROTOCOLS.load("standard", perturb_force_multiple=2.0)
    >>> result = protocol.run(scene, candidate, rng, deadline=time.monotonic() + 30.0, object_pose=rest)

A protocol's parameters are a frozen dataclass built strictly from keyword
arguments (`manigrasp.config.from_mapping`): a misspelled key is a
`ConfigError` that names the nearest valid one.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any, ClassVar, Generic, TypeVar

import numpy as np

from manigrasp.config import from_mapping
from manigrasp.protocol.execution import TrialRun
from manigrasp.protocol.grasp import Grasp
from manigrasp.protocol.observer import TrialObserver
from manigrasp.protocol.result import TrialResult
from manigrasp.protocol.trial import execute
from manigrasp.registry import Registry
from manigrasp.sim import Scene

P = TypeVar("P")


class Protocol(ABC, Generic[P]):
    """One kind of trial. Subclasses set `name` and `Params` and implement `run`.

    Args:
        params: the protocol's parameters (default: `Params()`).
    """

    name: ClassVar[str]
    Params: ClassVar[type]

    def __init__(self, params: P | None = None) -> None:
        self.params: P = params if params is not None else self.Params()

    @classmethod
    def from_params(cls, **params: Any) -> Protocol[P]:
        """Build with keyword parameters, refusing unknown keys (`ConfigError`)."""
        return cls(from_mapping(cls.Params, params, f"protocol.params ({cls.name})"))

    def run(self, scene: Scene, grasp: Any, rng: np.random.Generator, deadline: float | None = None, *,
            object_pose: np.ndarray | None = None, seed: int = 0,
            observer: TrialObserver | None = None) -> TrialResult:
        """Execute `grasp` in `scene` and return the trial's result (never raises for a trial fault).

        Args:
            scene: a compiled scene (it is reset; its model options are restored afterwards).
            grasp: a `GraspCandidate`, a `Grasp` or a (4, 4) TCP pose in the world.
            rng: the trial's random generator (for protocols that draw anything).
            deadline: `time.monotonic()` value after which the trial stops as `timeout`, or None.
            object_pose: (4, 4) settled object pose (from `settle_object`); None: settle here.
            seed: the trial's seed, copied into the result.
            observer: watches the trial (`protocol.observer.TrialObserver`: start, phases,
                samples every `sample_period_s` of simulated time, end), or None; the
                result is the same with or without one (wall time aside).
        """
        return execute(scene, grasp, self.params, self.body, deadline, object_pose, seed, observer=observer)

    @abstractmethod
    def body(self, run: TrialRun, pose: np.ndarray, rest: np.ndarray, grasp: Grasp) -> tuple[str, ...]:
        """The protocol's phases on a reset `run`: grasp pose (4, 4), settled object
        pose (4, 4), the grasp. Returns the finger bodies touching at the end on success; raises
        `execution.Abort` with the failure status otherwise."""


PROTOCOLS: Registry[Protocol[Any]] = Registry("protocol")


def register(cls: type[Protocol[Any]]) -> type[Protocol[Any]]:
    """Class decorator: register `cls` under `cls.name` with its strict keyword factory."""
    PROTOCOLS.add(cls.name, cls.from_params)
    return cls


def names() -> tuple[str, ...]:
    """Names of the registered protocols."""
    return PROTOCOLS.names()


def load(name: str, **params: Any) -> Protocol[Any]:
    """The protocol `name` (or ``module:attribute``) built with `params` (unknown keys refused)."""
    return PROTOCOLS.load(name, **params)
