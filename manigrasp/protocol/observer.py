"""Watching a trial without changing it: the hook recordings (rerun) and debugging use.

A protocol calls an observer at the start, at every phase change, every
`sample_period_s` of simulated time, and at the end. An observer only reads
the scene; with or without one, a trial's result is identical.
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

from manigrasp.protocol.result import Phase, TrialResult


@runtime_checkable
class TrialObserver(Protocol):
    """Callbacks of one trial. `scene` is a `manigrasp.sim.Scene`; read it, never write it.

    Attributes:
        sample_period_s: simulated time between `on_sample` calls [s] (e.g. 1/60);
            the protocol calls `on_sample` at the first step at or after each multiple.
    """

    sample_period_s: float

    def on_start(self, scene: Any, grasp: Any, object_pose: Any) -> None:
        """Before the first step: the grasp being executed (a `protocol.Grasp`) and the settled object pose."""

    def on_phase(self, scene: Any, phase: Phase, detail: str = "") -> None:
        """A phase begins (a `Phase`, a str enum: "pregrasp", "approach", "close", "lift", "perturb"...);
        `detail` e.g. "+x"."""

    def on_sample(self, scene: Any) -> None:
        """The state at a sample time (bodies, contacts, forces are readable from `scene`)."""

    def on_end(self, scene: Any, result: TrialResult) -> None:
        """After the last step, with the trial's result."""


class NullObserver:
    """An observer that does nothing (the default)."""

    sample_period_s = float("inf")

    def on_start(self, scene: Any, grasp: Any, object_pose: Any) -> None:  # noqa: D102
        pass

    def on_phase(self, scene: Any, phase: Phase, detail: str = "") -> None:  # noqa: D102
        pass

    def on_sample(self, scene: Any) -> None:  # noqa: D102
        pass

    def on_end(self, scene: Any, result: TrialResult) -> None:  # noqa: D102
        pass
