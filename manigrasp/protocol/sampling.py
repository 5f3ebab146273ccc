"""Stepping in chunks that stop at an observer's sample times (and nowhere else).

Splitting `mj_step(model, data, nstep=k)` into pieces gives the same state as
one call, so a trial observed every 1/60 s and one not observed at all are the
same trial: the sample times only add stops, never change a control update.
"""

from __future__ import annotations

import math

import mujoco

from manigrasp.protocol.observer import TrialObserver
from manigrasp.sim import Scene


class Sampler:
    """Advances a scene and calls `observer.on_sample` at the first step at or after each
    multiple of its `sample_period_s` of simulated time (`scene.time`).

    Args:
        scene: the scene being stepped.
        observer: the observer, or None (then stepping never stops early).
    """

    def __init__(self, scene: Scene, observer: TrialObserver | None) -> None:
        self.scene, self.observer = scene, observer
        period = float(observer.sample_period_s) if observer is not None else math.inf
        if not period > 0:
            raise ValueError(f"observer.sample_period_s must be > 0, got {period}")
        self.period = period
        self.next_time = period
        self.dt = float(scene.model.opt.timestep)

    def advance(self, n: int) -> None:
        """Step `n` times with the current controls, sampling on the way."""
        model, data = self.scene.model, self.scene.data
        while n > 0:
            k = n
            if math.isfinite(self.period):
                k = min(n, max(1, math.ceil((self.next_time - data.time) / self.dt - 1e-6)))
            mujoco.mj_step(model, data, nstep=k)
            n -= k
            if data.time >= self.next_time - 1e-6 * self.dt:
                self.observer.on_sample(self.scene)  # type: ignore[union-attr]
                while self.next_time <= data.time + 1e-6 * self.dt:
                    self.next_time += self.period
